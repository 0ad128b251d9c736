"""Polygons and footprints: containment, radii, circle approximation, padding."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.polygon import (
    Footprint,
    circle_polygon,
    pad_polygon,
    parse_footprint,
    point_segment_distance,
    points_in_polygon,
    polygon_area,
)

SQUARE = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
RECT = np.array([[0.5, 0.3], [0.5, -0.3], [-0.5, -0.3], [-0.5, 0.3]])


def test_points_in_square_both_windings() -> None:
    pts = np.array([[1.0, 1.0], [0.1, 1.9], [1.999, 0.001], [-0.1, 1.0], [2.1, 1.0],
                    [1.0, -0.001], [1.0, 2.5], [5.0, 5.0]])
    expected = [True, True, True, False, False, False, False, False]
    assert points_in_polygon(pts, SQUARE).tolist() == expected
    assert points_in_polygon(pts, SQUARE[::-1]).tolist() == expected


def test_points_in_concave_polygon() -> None:
    u_shape = np.array([[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]], float)
    pts = np.array([[0.5, 2.0], [1.5, 2.0], [2.5, 2.0], [1.5, 0.5]])
    assert points_in_polygon(pts, u_shape).tolist() == [True, False, True, True]


def test_rectangle_radii_area_and_placement() -> None:
    fp = Footprint.from_polygon(RECT)
    assert fp.inscribed_radius == pytest.approx(0.3)
    assert fp.circumscribed_radius == pytest.approx(math.hypot(0.5, 0.3))
    assert polygon_area(RECT) == pytest.approx(0.6)
    placed = fp.at((1.0, 2.0, math.pi / 2))
    assert np.allclose(placed[0], [1.0 - 0.3, 2.0 + 0.5])


def test_circle_polygon_contains_the_circle() -> None:
    r = 0.35
    poly = circle_polygon(r, n=16)
    fp = Footprint.from_polygon(poly)
    assert fp.inscribed_radius == pytest.approx(r, abs=1e-12)  # edges tangent to the circle
    assert fp.circumscribed_radius == pytest.approx(r / math.cos(math.pi / 16))
    a = np.linspace(0.0, 2.0 * math.pi, 720, endpoint=False)
    ring = (r - 1e-9) * np.column_stack((np.cos(a), np.sin(a)))
    assert points_in_polygon(ring, poly).all()
    with pytest.raises(ValueError, match=r"radius must be positive, got 0\.0"):
        circle_polygon(0.0)


def test_padding_moves_vertices_outward() -> None:
    padded = pad_polygon(RECT, 0.1)
    assert np.allclose(padded, [[0.6, 0.4], [0.6, -0.4], [-0.6, -0.4], [-0.6, 0.4]])
    fp = Footprint.from_polygon(RECT, padding=0.1)
    assert fp.inscribed_radius == pytest.approx(0.4)
    round_fp = Footprint.from_radius(0.2, padding=0.05)
    assert round_fp.radius == pytest.approx(0.25)
    assert round_fp.inscribed_radius == round_fp.circumscribed_radius == pytest.approx(0.25)


def test_parse_footprint_and_point_segment_distance() -> None:
    assert np.array_equal(parse_footprint("[[0.5, 0.3], [0.5, -0.3], [-0.5, -0.3], [-0.5, 0.3]]"),
                          RECT)
    with pytest.raises(ValueError, match="at least 3"):
        parse_footprint("[[0.5, 0.3], [0.5, -0.3]]")
    d = point_segment_distance(np.array([[0.0, 1.0], [-3.0, 4.0], [5.0, 0.0]]),
                               np.array([0.0, 0.0]), np.array([2.0, 0.0]))
    assert d == pytest.approx([1.0, 5.0, 3.0])

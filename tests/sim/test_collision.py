"""Footprint collision (static cells, moving circles and boxes) and clearance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.polygon import Footprint
from navstack.sim.collision import (
    _polygons_distance,
    clearance,
    footprint_clearance,
    footprint_collides,
    grid_clearance,
    grid_polygon_clearance,
    polygon_hits_grid,
)
from navstack.sim.world import MovingObstacle, World

RES = 0.05


def wall_world(moving: tuple[MovingObstacle, ...] = ()) -> World:
    """10 m x 5 m, empty except a wall of cells covering x in [5.0, 5.1)."""
    occ = np.zeros((100, 200), dtype=bool)
    occ[:, 100:102] = True
    return World(occ, RES, 0.0, 0.0, moving_obstacles=moving)


def square(cx: float, cy: float, half: float) -> np.ndarray:
    return np.array([[cx - half, cy - half], [cx + half, cy - half], [cx + half, cy + half],
                     [cx - half, cy + half]])


def test_touching_a_wall_collides_one_cell_away_does_not() -> None:
    w = wall_world()
    assert footprint_collides(w, square(4.8, 2.5, 0.2), 0.0)             # right edge at 5.0
    assert not footprint_collides(w, square(4.8 - RES, 2.5, 0.2), 0.0)   # gap of one cell
    assert footprint_collides(w, square(5.05, 2.5, 0.2), 0.0)            # straddling
    assert not footprint_collides(w, square(5.3 + RES, 2.5, 0.2), 0.0)   # one cell beyond
    assert footprint_collides(w, square(5.3, 2.5, 0.2), 0.0)             # left edge at 5.1


def test_corner_clip_without_any_cell_centre_inside() -> None:
    occ = np.zeros((40, 40), dtype=bool)
    occ[20, 20] = True  # square [1.0, 1.05] x [1.0, 1.05]
    w = World(occ, RES)
    # triangle whose corner pokes 5 mm into the cell's lower-left corner
    tri = np.array([[0.5, 0.5], [1.005, 1.005], [0.5, 1.0]])
    assert footprint_collides(w, tri, 0.0)
    assert not footprint_collides(w, tri - 0.01, 0.0)
    # an edge crossing the cell without any vertex inside it
    thin = np.array([[0.9, 0.9], [1.2, 1.06], [0.9, 0.95]])
    assert footprint_collides(w, thin, 0.0)
    # a footprint wholly containing the occupied cell
    assert footprint_collides(w, square(1.02, 1.02, 0.3), 0.0)


def test_footprint_inside_an_occupied_block() -> None:
    occ = np.zeros((40, 40), dtype=bool)
    occ[10:30, 10:30] = True
    w = World(occ, RES)
    assert footprint_collides(w, square(1.0, 1.0, 0.1), 0.0)


def test_rotated_robot_footprint() -> None:
    w = wall_world()
    fp = Footprint.from_polygon([[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]])
    # rotated 90 degrees, the 0.2 half-width faces the wall
    assert not footprint_collides(w, fp.at((4.79, 2.5, math.pi / 2)), 0.0)
    assert footprint_collides(w, fp.at((4.79, 2.5, 0.0)), 0.0)


def test_moving_circle_contact_at_known_time() -> None:
    walker = MovingObstacle("walker", "circle", np.array([[0.0, 2.0], [4.0, 2.0]]), 1.0,
                            "pingpong", radius=0.3)
    w = wall_world((walker,))
    fp = square(3.2, 2.0, 0.2)  # left edge at x = 3.0: contact when the centre is at 2.7
    assert not footprint_collides(w, fp, 2.6)
    assert footprint_collides(w, fp, 2.7)
    assert footprint_collides(w, fp, 2.75)
    assert footprint_collides(w, fp, 5.0)      # on its way back, centre at 3.0
    assert not footprint_collides(w, fp, 5.31)  # centre 2.69
    # a circle wholly inside a large footprint
    assert footprint_collides(w, square(1.0, 2.0, 0.8), 1.0)


def test_moving_box_contact() -> None:
    cart = MovingObstacle("cart", "box", np.array([[1.0, 1.0], [1.0, 4.0]]), 0.5, "loop",
                          size=(1.0, 0.4))
    w = wall_world((cart,))
    # at t = 2 the cart is at (1.0, 2.0) heading +y: spans x 0.8..1.2, y 1.5..2.5
    assert footprint_collides(w, square(1.4, 2.0, 0.2), 2.0)       # touching x = 1.2
    assert not footprint_collides(w, square(1.41, 2.0, 0.2), 2.0)
    assert footprint_collides(w, square(1.0, 2.0, 0.05), 2.0)      # inside the cart
    assert footprint_collides(w, square(1.0, 2.0, 2.0), 2.0)       # containing the cart
    assert not footprint_collides(w, square(1.0, 2.7, 0.15), 2.0)  # 0.05 in front
    assert footprint_collides(w, square(1.0, 2.7, 0.15), 2.2)      # cart moved 0.1


def test_clearance_static_and_moving() -> None:
    walker = MovingObstacle("walker", "circle", np.array([[2.0, 1.0], [2.0, 4.0]]), 1.0,
                            radius=0.25)
    w = wall_world((walker,))
    assert clearance(w, 2.0, 4.5, 0.0, 10.0) == pytest.approx(3.0)     # wall face x = 5
    assert clearance(w, 2.0, 2.0, 0.0, 10.0) == pytest.approx(0.75)    # walker at y = 1
    assert clearance(w, 2.0, 2.0, 0.0, 0.5) == pytest.approx(0.5)      # capped
    assert clearance(w, 5.05, 2.0, 0.0, 10.0) == 0.0                   # inside the wall
    assert clearance(w, 2.0, 1.1, 0.0, 10.0) == 0.0                    # inside the walker
    assert clearance(w, 6.1, 2.0, 0.0, 10.0) == pytest.approx(1.0)     # wall back face 5.1
    assert clearance(w, 4.0, 2.3, 0.0, 10.0) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="max_dist"):
        clearance(w, 1.0, 1.0, 0.0, math.inf)


def test_footprint_clearance_measures_from_the_outline() -> None:
    """A 2.9 m x 1.2 m cart body: the outline's distance, not a circle's about the axle."""
    walker = MovingObstacle("walker", "circle", np.array([[1.5, 0.5], [1.5, 4.5]]), 1.0,
                            radius=0.25)
    box = MovingObstacle("cart", "box", np.array([[9.0, 1.0], [9.0, 4.0]]), 1.0,
                         size=(0.6, 0.6), yaw=0.0)
    w = wall_world((walker, box))
    body = Footprint.from_polygon([[2.65, 0.6], [2.65, -0.6], [-0.25, -0.6], [-0.25, 0.6]])
    # rear axle at (1.0, 3.5) facing +x: the nose at x = 3.65 is 1.35 m from the wall face
    assert footprint_clearance(w, body.at((1.0, 3.5, 0.0)), 0.0, 5.0) == pytest.approx(1.35)
    # facing +y: the side at x = 1.6 is 3.4 m from the wall; the walker (y = 0.5, r 0.25)
    # is below the rear edge y = 3.25: 2.5 m
    assert footprint_clearance(w, body.at((1.0, 3.5, math.pi / 2)), 0.0, 5.0) == \
        pytest.approx(2.5)
    assert footprint_clearance(w, body.at((1.0, 3.5, 0.0)), 0.0, 1.0) == 1.0  # capped
    assert footprint_clearance(w, body.at((2.5, 2.0, 0.0)), 0.0, 5.0) == 0.0  # nose in the wall
    # past the wall (tail 0.55 m from its back face), the box (x in [8.7, 9.3] at y = 1)
    # is 0.15 m ahead of the nose at x = 8.55
    assert footprint_clearance(w, body.at((5.9, 1.0, 0.0)), 0.0, 5.0) == pytest.approx(0.15)
    with pytest.raises(ValueError, match="max_dist"):
        footprint_clearance(w, body.at((1.0, 1.0, 0.0)), 0.0, math.inf)


def test_grid_clearance_matches_brute_force() -> None:
    rng = np.random.default_rng(9)
    occ = rng.random((60, 80)) < 0.01
    ox, oy, res = -1.0, 0.5, 0.1
    r, c = np.nonzero(occ)
    for x, y in rng.uniform([ox - 1, oy - 1], [ox + 9, oy + 7], size=(200, 2)):
        dx = np.maximum.reduce([ox + c * res - x, np.zeros(len(c)), x - ox - (c + 1) * res])
        dy = np.maximum.reduce([oy + r * res - y, np.zeros(len(r)), y - oy - (r + 1) * res])
        expect = min(float(np.hypot(dx, dy).min()), 3.0)
        assert grid_clearance(occ, ox, oy, res, float(x), float(y), 3.0) == \
            pytest.approx(expect, abs=1e-12)


def test_grid_polygon_clearance_is_the_minimum_over_every_occupied_cell() -> None:
    """The nearest-first search with its early stops finds exactly the brute-force
    minimum of the polygon-to-square distance over all occupied cells (capped)."""
    rng = np.random.default_rng(4)
    occ = rng.random((60, 80)) < 0.02
    ox, oy, res = -1.0, 0.5, 0.1
    rows, cols = np.nonzero(occ)
    body = np.array([[0.3, 0.2], [-0.25, 0.2], [-0.3, 0.0], [-0.25, -0.2], [0.3, -0.2]])
    checked = 0
    for x, y, th, cap in zip(rng.uniform(ox - 1, ox + 9, 300), rng.uniform(oy - 1, oy + 7, 300),
                             rng.uniform(-math.pi, math.pi, 300),
                             rng.choice([0.3, 1.0, 3.0], 300), strict=True):
        rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        poly = np.ascontiguousarray(body @ rot.T + [x, y])
        if polygon_hits_grid(occ, ox, oy, res, poly):
            continue
        expect = float(cap)
        for r, c in zip(rows, cols, strict=True):
            x0, y0 = ox + c * res, oy + r * res
            sq = np.array([[x0, y0], [x0 + res, y0], [x0 + res, y0 + res], [x0, y0 + res]])
            expect = min(expect, _polygons_distance(poly, sq))
        assert grid_polygon_clearance(occ, ox, oy, res, poly, float(cap)) == expect
        checked += 1
    assert checked > 150

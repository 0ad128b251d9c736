"""Marker map fusion: outlier rejection, upright orientation, publication, YAML."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.rotations import rotation_angle
from navstack.perception.aruco.marker_map import (
    MarkerMap,
    MarkerMapParams,
    Sighting,
    upright_rotation,
)
from navstack.perception.package_cloud import package_cloud, ring_points

TRUTH = np.array([2.0, 3.0, 0.4])
YAW = 0.7


def _sighting(rng: np.random.Generator, noise: float = 0.01, yaw: float = YAW,
              offset: float = 0.0, ambiguity: float = 0.1, distance: float = 1.5) -> Sighting:
    pos = TRUTH + rng.normal(0.0, noise, 3) + offset
    rot = upright_rotation(yaw + rng.normal(0.0, 0.02))
    return Sighting(pos, rot, np.eye(3) * noise ** 2, 0.0, ambiguity, distance)


def test_outliers_and_flipped_views_do_not_move_the_estimate() -> None:
    rng = np.random.default_rng(0)
    mm = MarkerMap(MarkerMapParams(position_floor=0.01))
    for i in range(40):
        if i % 5 == 0:   # a wrong association half a metre off
            mm.add(5, _sighting(rng, offset=0.5))
        elif i % 7 == 0:  # an IPPE flip: facing mirrored, both solutions fit alike
            mm.add(5, _sighting(rng, yaw=YAW + 0.8, ambiguity=0.9))
        else:
            mm.add(5, _sighting(rng))
    e = mm.estimate(5)
    assert e is not None and e.published
    assert np.linalg.norm(e.position - TRUTH) < 0.005
    assert e.inliers <= 40 - 8
    assert math.degrees(rotation_angle(e.rotation, upright_rotation(YAW))) < 1.0
    assert np.all(np.linalg.eigvalsh(e.covariance) > 0.0)


def test_published_after_min_sightings_and_far_views_ignored() -> None:
    rng = np.random.default_rng(1)
    mm = MarkerMap(MarkerMapParams(min_sightings=3, max_distance=3.0))
    assert mm.add(1, _sighting(rng, distance=3.5)) is None
    assert mm.rejected_far == 1
    for n in range(1, 4):
        e = mm.add(1, _sighting(rng))
        assert e is not None and e.published == (n >= 3)
    assert [x.id for x in mm.estimates()] == [1]


def test_save_and_load_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    mm = MarkerMap()
    for _ in range(10):
        mm.add(7, _sighting(rng), size=0.15)
    path = mm.save(tmp_path / "maps" / "markers.yaml")
    loaded = MarkerMap.load(path)
    a, b = mm.estimate(7), loaded.estimate(7)
    assert a is not None and b is not None and b.published
    assert np.allclose(a.position, b.position, atol=1e-6) and b.size == 0.15
    assert rotation_angle(a.rotation, b.rotation) < 1e-6
    # a loaded marker is refined by new sightings
    for _ in range(5):
        loaded.add(7, _sighting(rng))
    assert np.linalg.norm(loaded.estimate(7).position - TRUTH) < 0.01  # type: ignore[union-attr]


def test_bad_marker_map_files(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("markers:\n  - {id: 3, position: [1, 2]}\n")
    with pytest.raises(ConfigError, match=r"bad.yaml: markers\[0\]: invalid marker entry"):
        MarkerMap.load(bad)
    dup = tmp_path / "dup.yaml"
    dup.write_text("markers:\n  - {id: 3, position: [1, 2, 0], orientation: [0, 0, 0, 1]}\n"
                   "  - {id: 3, position: [1, 2, 0], orientation: [0, 0, 0, 1]}\n")
    with pytest.raises(ConfigError, match="marker 3 appears twice"):
        MarkerMap.load(dup)
    with pytest.raises(ConfigError, match="marker map file not found"):
        MarkerMap.load(tmp_path / "none.yaml")


def test_package_ring_is_the_course_ring() -> None:
    ring = ring_points(1.0, 2.0)
    assert ring.shape == (25, 3)
    assert np.allclose(np.hypot(ring[:, 0] - 1.0, ring[:, 1] - 2.0), 0.15)
    assert np.allclose(ring[:, 2], 0.05)
    assert package_cloud([(0, 0), (1, 1)]).shape == (50, 3)
    assert package_cloud([]).shape == (0, 3)

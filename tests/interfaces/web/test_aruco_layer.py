"""The dashboard shows the marker map: markers and packages in the state stream."""

from __future__ import annotations

import math

import numpy as np

from navstack.core.msgs import Header, MarkerArray
from navstack.core.msgs.fiducial_msgs import MARKER_MAP_VIZ_TOPIC
from navstack.interfaces.foxglove_markers import marker_array_scene
from navstack.interfaces.stack import NavStack
from navstack.nodes.marker_map import _package_visual, _visual
from navstack.perception.aruco.marker_map import MarkerEstimate, upright_rotation
from navstack.runtime.bus import LATCHED
from tests.interfaces.web.conftest import Live, wait_until


def _viz() -> MarkerArray:
    est = MarkerEstimate(12, np.array([0.8, 5.0, 0.45]), upright_rotation(0.0),
                         np.eye(3) * 1e-4, 10, 10, 0.0, 1.0, 0.15, True)
    head = Header(0.0, "map")
    return MarkerArray((*_visual(est, head), *_package_visual(3, 2.0, 1.0, 0.3, head)))


def test_state_lists_markers_and_packages(live: Live) -> None:
    def publish(stack: NavStack) -> None:
        stack.runtime.bus.publisher(MARKER_MAP_VIZ_TOPIC, MarkerArray, LATCHED).publish(_viz())

    live.runner.call(publish)
    state = wait_until(lambda: (s := live.state()).get("aruco") and s, 10.0, "aruco in state")
    assert sorted(map(tuple, state["aruco"])) == [(3, 2.0, 1.0, 0.0, "package"),
                                                 (12, 0.8, 5.0, 0.0, "marker")]


def test_foxglove_scene_of_the_marker_map() -> None:
    scene = marker_array_scene(_viz(), 1_500_000_000)
    data = scene.encode()
    for entity in (b"aruco_markers/12", b"aruco_marker_ids/12", b"packages/3", b"package 3"):
        assert entity in data
    assert math.isfinite(len(data))

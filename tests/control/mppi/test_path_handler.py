"""Plan pruning (Nav2 PathHandler semantics)."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.control.mppi import MPPIInvalidPath, MPPIParams
from navstack.control.mppi.path_handler import (
    PathHandler,
    first_after_integrated_distance,
    first_inversion_end,
)
from navstack.core.geometry import se2_compose
from tests.control.mppi.helpers import costmap, straight_plan


def test_integrated_distance_and_cusp_indices() -> None:
    xy = straight_plan(1.0, ds=0.1)[:, :2]
    assert first_after_integrated_distance(xy, 0, 0.35) == 4  # 0.4 m > 0.35 m
    assert first_after_integrated_distance(xy, 5, 0.15) == 7
    assert first_after_integrated_distance(xy, 0, 5.0) == len(xy)
    forth_back = np.array([[0, 0], [1, 0], [2, 0], [1.5, 0], [1, 0]], dtype=float)
    assert first_inversion_end(forth_back) == 3  # keeps the cusp at index 2
    assert first_inversion_end(xy) == len(xy)


def test_local_plan_is_pruned_and_bounded() -> None:
    handler = PathHandler(MPPIParams(prune_distance=1.0))
    handler.set_path(straight_plan(5.0))
    cm = costmap()
    local = handler.transform_path((1.02, 0.1, 0.0), cm)
    np.testing.assert_allclose(local[0], [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(local[-1], [2.0, 0.0, 0.0], atol=1e-9)  # 1 m of path
    assert len(handler.remaining) == len(straight_plan(5.0)) - 20  # passed poses dropped
    # the local plan stops at the costmap edge (x = 4)
    local = handler.transform_path((3.5, 0.0, 0.0), costmap())
    assert local[-1, 0] < 4.0 and len(local) == 10
    with pytest.raises(MPPIInvalidPath, match="zero poses"):
        PathHandler(MPPIParams()).transform_path((0.0, 0.0, 0.0), cm)


def test_search_distance_ignores_a_plan_looping_back() -> None:
    out = straight_plan(3.0)
    back = out[::-1].copy()[1:]
    back[:, 1] = 0.3
    handler = PathHandler(MPPIParams(max_robot_pose_search_dist=1.0))
    handler.set_path(np.vstack((out, back)))
    # near the end of the return leg (x ~ 0.1, y = 0.3) but only 1 m of plan is searched
    local = handler.transform_path((0.1, 0.3, 0.0), costmap())
    assert local[0, 1] == 0.0 and local[0, 0] <= 1.0


def test_rigidly_moved_plan_keeps_progress() -> None:
    handler = PathHandler(MPPIParams())
    plan = straight_plan(4.0)
    handler.set_path(plan)
    handler.transform_path((2.0, 0.0, 0.0), costmap())
    done = len(plan) - len(handler.remaining)
    moved = se2_compose(np.array([0.3, -0.2, 0.05]), plan)
    handler.set_path(moved)
    assert len(plan) - len(handler.remaining) == done
    handler.set_path(straight_plan(2.0))  # a different plan restarts
    assert len(handler.remaining) == len(straight_plan(2.0))


def test_enforced_inversion_releases_the_rest_at_the_cusp() -> None:
    forward = straight_plan(1.0)
    backward = forward[::-1][1:].copy()
    backward[:, 1] = -np.linspace(0.0, 0.5, len(backward))
    plan = np.vstack((forward, backward))
    handler = PathHandler(MPPIParams(enforce_path_inversion=True))
    handler.set_path(plan)
    local = handler.transform_path((0.0, 0.0, 0.0), costmap())
    assert len(handler.remaining) == len(forward)
    np.testing.assert_allclose(local[-1, :2], [1.0, 0.0], atol=1e-9)
    # within 0.2 m and 0.4 rad of the cusp pose: the plan after it is released
    handler.transform_path((0.9, 0.0, 0.1), costmap())
    assert len(handler.remaining) == len(backward)
    np.testing.assert_allclose(handler.goal(), plan[-1])

"""Oriented-footprint path check and replanning (planning/footprint_path.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from navstack.core.errors import ConfigError, NoValidPath
from navstack.core.msgs import Path, Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, Costmap2D
from navstack.navigation.planner_server import PlannerServerParams
from navstack.planning.footprint_path import (
    densify,
    first_footprint_collision,
    footprint_misfits,
    path_headings,
    plan_footprint_checked,
)
from navstack.planning.navfn import NavfnPlanner

RES = 0.05
# the TurtleBot3 Waffle Pi's body (axle 0.076 m behind the front edge) padded by 0.03 m
WAFFLE = Footprint.from_polygon([[-0.205, -0.153], [-0.205, 0.153], [0.076, 0.153],
                                 [0.076, -0.153]], padding=0.03)


def inflated(lethal: np.ndarray, inscribed: float = 0.106, radius: float = 0.55,
             scaling: float = 3.0) -> Costmap2D:
    """Nav2's inflation of a lethal mask (cost 253 within the inscribed radius, then
    252 exp(-scaling (d - inscribed)) out to the inflation radius)."""
    dist = distance_transform_edt(~lethal) * RES
    cost = np.where(dist <= inscribed, 253,
                    np.where(dist <= radius, 252 * np.exp(-scaling * (dist - inscribed)), 0))
    data = cost.astype(np.uint8)
    data[lethal] = LETHAL_OBSTACLE
    return Costmap2D.from_array(data, RES)


def arena(gap_post_y: float | None) -> Costmap2D:
    """4 x 3 m: a partition from the south edge up to y = 1.2 at x = 2.0, and optionally a
    post (0.15 m radius, a package's ring) at (2.0, gap_post_y) north of its end."""
    h, w = 60, 80
    yy, xx = np.mgrid[0:h, 0:w]
    cx, cy = (xx + 0.5) * RES, (yy + 0.5) * RES
    lethal = (np.abs(cx - 2.0) <= 0.05) & (cy <= 1.2)
    lethal |= (cx < 0.05) | (cx > 3.95) | (cy < 0.05) | (cy > 2.95)
    if gap_post_y is not None:
        lethal |= np.hypot(cx - 2.0, cy - gap_post_y) <= 0.15
    return inflated(lethal)


START, GOAL = Pose2D(1.0, 0.6, 0.0), Pose2D(3.0, 0.6, 0.0)


def crossing_y(path_xy: np.ndarray) -> float:
    """Where the path crosses x = 2.0 (the partition's line)."""
    k = int(np.argmin(np.abs(path_xy[:, 0] - 2.0)))
    return float(path_xy[k, 1])


def test_path_headings_follow_the_chord() -> None:
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    th = path_headings(densify(xy, 0.05), 0.12)
    assert th[0] == pytest.approx(0.0)
    assert th[10] == pytest.approx(0.0)
    assert th[-1] == pytest.approx(math.pi / 2)
    assert th[20] == pytest.approx(math.pi / 4, abs=1e-9)  # the corner: the chord across
    assert path_headings(np.zeros((1, 2)), 0.15).tolist() == [0.0]


def test_densify_spacing_keeps_the_vertices() -> None:
    xy = np.array([[0.0, 0.0], [0.3, 0.0], [0.3, 0.1]])
    d = densify(xy, 0.025)
    steps = np.hypot(*np.diff(d, axis=0).T)
    assert steps.max() <= 0.025 + 1e-12
    assert len(d) == 1 + 12 + 4
    assert d[12].tolist() == [0.3, 0.0]
    assert d[-1].tolist() == [0.3, 0.1]


def test_a_gap_narrower_than_the_body_is_a_misfit_but_a_wide_one_is_not() -> None:
    cm = arena(1.78)  # 0.43 m between the partition's end and the post
    through_gap = np.array([[1.0, 1.44], [3.0, 1.44]])
    hit = first_footprint_collision(cm, through_gap, WAFFLE, 0.05, 0.15, 0.15, 0.25, 0.15)
    assert hit is not None
    assert hit[0] == pytest.approx(2.0, abs=0.3)
    above = np.array([[1.0, 2.45], [3.0, 2.45]])  # 0.47 m from the post, 0.5 from the edge
    assert first_footprint_collision(cm, above, WAFFLE, 0.05, 0.15, 0.15, 0.25, 0.15) is None


def test_hugging_an_obstacle_is_not_a_misfit_when_a_sideways_shift_fits() -> None:
    cm = arena(None)
    hug = np.array([[1.0, 1.35], [3.0, 1.35]])  # passes 0.15 m over the partition's end
    assert first_footprint_collision(cm, hug, WAFFLE, 0.05, 0.15, 0.15, 0.25, 0.0) is not None
    assert first_footprint_collision(cm, hug, WAFFLE, 0.05, 0.15, 0.15, 0.25, 0.15) is None


def test_the_ends_of_the_path_are_not_judged() -> None:
    cm = arena(1.78)
    short = np.array([[2.0, 1.44], [2.1, 1.44]])  # starts in the gap
    assert first_footprint_collision(cm, short, WAFFLE, 0.05, 0.15, 0.15, 0.25, 0.15) is None


def test_replanning_goes_round_the_gap_the_body_does_not_fit() -> None:
    cm = arena(1.78)
    planner = NavfnPlanner()
    plain = planner.plan(START, GOAL, cm).as_array()
    assert 1.2 < crossing_y(plain[:, :2]) < 1.63  # NavFn: through the 0.43 m gap
    result = plan_footprint_checked(lambda c: planner.plan(START, GOAL, c), cm, WAFFLE)
    assert result.clear
    assert result.blocked and result.plans == len(result.blocked) + 1
    xy = result.path.as_array()[:, :2]
    assert crossing_y(xy) > 1.93  # north of the post
    assert xy[0] == pytest.approx([START.x, START.y], abs=RES)
    assert xy[-1] == pytest.approx([GOAL.x, GOAL.y], abs=RES)
    assert np.array_equal(cm.data, arena(1.78).data)  # the blocked discs were on a copy


def test_a_wide_gap_is_planned_through_unchanged() -> None:
    cm = arena(2.4)  # 1.05 m between the partition's end and the post
    planner = NavfnPlanner()
    result = plan_footprint_checked(lambda c: planner.plan(START, GOAL, c), cm, WAFFLE)
    assert result.clear and result.blocked == [] and result.plans == 1
    plain = planner.plan(START, GOAL, cm).as_array()
    assert np.allclose(result.path.as_array(), plain)


def test_the_only_way_through_a_narrow_gap_keeps_the_planners_path() -> None:
    cm = arena(1.78)
    # close the way round the post: a wall from the post to the north edge
    data = cm.data.copy()
    data[36:, 39:42] = LETHAL_OBSTACLE
    walled = Costmap2D.from_array(data, RES)
    planner = NavfnPlanner()
    plain = planner.plan(START, GOAL, walled).as_array()
    result = plan_footprint_checked(lambda c: planner.plan(START, GOAL, c), walled, WAFFLE)
    assert not result.clear
    assert np.allclose(result.path.as_array(), plain)


def test_planner_server_footprint_check_options_are_validated() -> None:
    assert PlannerServerParams().footprint_check is False  # Nav2's behaviour by default
    with pytest.raises(ConfigError, match="footprint_check_margin"):
        PlannerServerParams.from_mapping({"footprint_check_margin": -0.1})
    with pytest.raises(ConfigError, match="footprint_check_block_radius"):
        PlannerServerParams.from_mapping({"footprint_check_block_radius": 0.0})


def lowest_free_line(cm: Costmap2D) -> Path:
    """A planner of straight lines from x = 1 to 3 m: the lowest y >= 1.3 m whose cells
    are all below INSCRIBED_INFLATED_OBSTACLE (what NavFn may cross)."""
    for y in np.arange(1.3, 2.9, RES):
        xs = np.arange(1.0, 3.0 + 1e-9, 0.5 * RES)
        mx, my, _ = cm.world_to_map_array(np.column_stack((xs, np.full_like(xs, y))))
        if np.all(cm.data[my, mx] < INSCRIBED_INFLATED_OBSTACLE):
            return Path.from_array(np.column_stack((xs, np.full_like(xs, y),
                                                    np.zeros_like(xs))))
    raise NoValidPath("no free line")


def test_a_path_that_hugs_an_obstacle_is_pushed_off_it() -> None:
    cm = arena(None)
    first = lowest_free_line(cm).as_array()
    y0 = float(first[0, 1])
    assert y0 <= 1.35  # at most 0.15 m over the partition's end
    hugs = footprint_misfits(cm, np.ascontiguousarray(first[:, :2]), WAFFLE, 0.05, 0.15,
                             0.15, 0.25, 0.15)
    assert hugs and all(m.shift is not None and m.shift > 0 for m in hugs)
    needed = max(m.shift for m in hugs if m.shift is not None)
    result = plan_footprint_checked(lowest_free_line, cm, WAFFLE)
    assert result.clear and result.gap_free and result.replaced
    y = float(result.path.as_array()[0, 1])
    assert y0 + needed - 1e-9 <= y <= y0 + needed + 2 * RES  # pushed, not detoured
    # the discs (radius 0.1 m) lie between the partition and the new path
    assert result.blocked and all(y0 <= by and by + 0.1 <= y + 1e-9 for _, by in result.blocked)


@pytest.mark.parametrize("check", [False, True])
def test_planner_server_plans_round_the_gap_with_footprint_check(check: bool) -> None:
    from navstack.core.msgs import PoseStamped
    from navstack.navigation.costmap_node import CostmapNode
    from navstack.navigation.planner_server import PlannerServer
    from navstack.runtime.node import Runtime
    from navstack.runtime.scheduler import Scheduler

    rt = Runtime(Scheduler("sim"))
    node = CostmapNode(rt, "global_costmap", {"global_frame": "map", "width": 4, "height": 3,
                                              "resolution": RES, "plugins": []})
    node.costmap.data[:] = arena(1.78).data
    server = PlannerServer(rt, {"footprint_check": check}, node, footprint=WAFFLE)
    server.configure()
    path = server.compute_path(PoseStamped.from_pose2d(GOAL, "map"),
                               PoseStamped.from_pose2d(START, "map"))
    y = crossing_y(path.as_array()[:, :2])
    assert (y > 1.93) if check else (1.2 < y < 1.63)
    assert server.footprint_replans == int(check)

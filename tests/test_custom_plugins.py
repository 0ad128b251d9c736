"""Acceptance (issue 14, part 1): plugins of one's own, each one class with one decorator,
loaded by its Nav2 type string from a Nav2 YAML and run in the stack in the simulator.

``my_pkg`` below is what a user's package would hold: a global planner through
mandatory via points, a DWB critic and an MPPI critic that cap the speed, and a costmap
layer that marks a keep-off zone.  The YAML overlay names them exactly as Nav2 names its
own plugins (``plugin: "my_pkg/ViaPointPlanner"``, ``class: "my_pkg::SpeedCapCritic"``,
``critics: [..., "my_pkg::SpeedCapCritic"]``) over the packaged ``nav2_params.yaml``.

The plugins are registered inside a fixture wrapped in ``scoped(...)`` so the rest of the
test session sees the built-in registries only.  ``docs/extending.md`` shows the same four
plugins; the last test executes its code blocks.
"""

from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import yaml
from numpy.typing import NDArray
from pydantic import Field

from navstack.control.dwb.critic_base import CRITICS as DWB_CRITICS
from navstack.control.dwb.critic_base import CriticContext, CriticParams, TrajectoryCritic
from navstack.control.dwb.critic_base import register_critic as register_dwb_critic
from navstack.control.dwb.trajectory_generator import TrajectoryBatch
from navstack.control.mppi.critics import CRITICS as MPPI_CRITICS
from navstack.control.mppi.critics import Critic, CriticData, WeightedCriticParams
from navstack.control.mppi.critics import register_critic as register_mppi_critic
from navstack.core.interfaces import CancelFn, GlobalPlanner
from navstack.core.msgs import Path as PathMsg
from navstack.core.msgs import Pose2D, PoseStamped
from navstack.core.params import Params
from navstack.core.plugins import PLANNERS, register_planner
from navstack.core.registry import scoped
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from navstack.costmap.layer import (
    COSTMAP_LAYERS,
    Bounds,
    CellWindow,
    Layer,
    LayerParams,
    register_layer,
)
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.stack import NavStack, default_nav2_params_path
from navstack.planning.navfn import NavfnParams, NavfnPlanner

ZONE = (3.0, 1.5, 4.0, 3.1)
"""The keep-off zone [m] (min_x, min_y, max_x, max_y): an island across the straight
route, with a 1.8 m passage north of it and a 1.4 m one south."""
VIA = (3.5, 0.8)
"""The via point [m]: in the narrower south passage; the shortest path takes the north
one."""
START, GOAL = Pose2D(1.0, 2.5, 0.0), Pose2D(8.5, 2.5, 0.0)

WORLD = """\
name: plugin_room
resolution: 0.05
size: [10.0, 5.0]
boundary: true
boundary_thickness: 0.1
spawn: {x: 1.0, y: 2.5, yaw: 0.0}
"""

OVERLAY = """\
planner_server:
  ros__parameters:
    planner_plugins: ["GridBased"]
    GridBased:
      plugin: "my_pkg/ViaPointPlanner"
      via_points: [[3.5, 0.8]]
global_costmap:
  global_costmap:
    ros__parameters:
      plugins: ["static_layer", "obstacle_layer", "keep_off", "inflation_layer"]
      keep_off:
        plugin: "my_pkg/KeepOffLayer"
        zone: [3.0, 1.5, 4.0, 3.1]
"""

DWB_OVERLAY = """\
controller_server:
  ros__parameters:
    FollowPath:
      critics: ["RotateToGoal", "Oscillation", "BaseObstacle", "GoalAlign", "PathAlign",
                "PathDist", "GoalDist", "SpeedCap"]
      SpeedCap:
        class: "my_pkg::SpeedCapCritic"
        max_speed: 0.2
"""

MPPI_OVERLAY = """\
controller_server:
  ros__parameters:
    FollowPath:
      critics: ["ConstraintCritic", "CostCritic", "GoalCritic", "GoalAngleCritic",
                "PathAlignCritic", "PathFollowCritic", "PathAngleCritic",
                "PreferForwardCritic", "my_pkg::SpeedCapCritic"]
      SpeedCapCritic: {cost_weight: 50.0, max_speed: 0.2}
"""


@pytest.fixture
def my_pkg() -> Iterator[SimpleNamespace]:
    """The user's package: four plugins, one decorator each."""
    with scoped(PLANNERS, COSTMAP_LAYERS, DWB_CRITICS, MPPI_CRITICS):

        class ViaPointParams(Params):
            via_points: list[tuple[float, float]] = Field(default_factory=list)

        @register_planner("ViaPoint", nav2="my_pkg/ViaPointPlanner")
        class ViaPointPlanner(GlobalPlanner):
            """Shortest path through every via point in order (NavFn legs)."""

            params_model = ViaPointParams
            params: ViaPointParams

            def __init__(self, params: ViaPointParams | None = None) -> None:
                super().__init__(params)
                self.legs = NavfnPlanner(NavfnParams(use_astar=True))
                self.plans: list[PathMsg] = []

            def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap2D,
                     cancel: CancelFn | None = None) -> PathMsg:
                stops = [start, *(Pose2D(x, y, 0.0) for x, y in self.params.via_points), goal]
                legs = [self.legs.plan(a, b, costmap, cancel).as_array()
                        for a, b in itertools.pairwise(stops)]
                path = PathMsg.from_array(np.concatenate([legs[0], *(g[1:] for g in legs[1:])]),
                                          costmap.frame_id)
                self.plans.append(path)
                return path

        class KeepOffParams(LayerParams):
            zone: tuple[float, float, float, float]  # min_x, min_y, max_x, max_y [m]

        @register_layer("KeepOffLayer", nav2="my_pkg::KeepOffLayer")
        class KeepOffLayer(Layer):
            """Marks a rectangle lethal (a virtual wall)."""

            params_model = KeepOffParams
            params: KeepOffParams

            def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                              bounds: Bounds) -> Bounds:
                x0, y0, x1, y1 = self.params.zone
                bounds.touch(x0, y0)
                bounds.touch(x1, y1)
                return bounds

            def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
                x0, y0, x1, y1 = self.params.zone
                res = master.resolution
                xs = master.origin_x + (np.arange(window.min_i, window.max_i) + 0.5) * res
                ys = master.origin_y + (np.arange(window.min_j, window.max_j) + 0.5) * res
                inside = (((ys >= y0) & (ys <= y1))[:, None]
                          & ((xs >= x0) & (xs <= x1))[None, :])
                master.data[window.slices][inside] = LETHAL_OBSTACLE
                self.current = True

        class SpeedCapParams(CriticParams):
            max_speed: float = Field(0.5, gt=0.0)

        @register_dwb_critic("SpeedCap", namespace="my_pkg")
        class SpeedCapCritic(TrajectoryCritic[SpeedCapParams]):
            """Rejects samples faster than ``max_speed``."""

            params_model = SpeedCapParams
            reasons = ("faster than max_speed",)

            def score(self, batch: TrajectoryBatch, ctx: CriticContext
                      ) -> NDArray[np.float64]:
                fast = np.abs(batch.velocities[:, 0]) > self.params.max_speed + 1e-9
                return np.where(fast, -1.0, 0.0)

        class MPPISpeedCapParams(WeightedCriticParams):
            max_speed: float = Field(0.5, gt=0.0)

        @register_mppi_critic("SpeedCapCritic", namespace="my_pkg")
        class MPPISpeedCapCritic(Critic):
            """Adds ``cost_weight * integral of max(vx - max_speed, 0) dt`` per sample."""

            params_model = MPPISpeedCapParams
            params: MPPISpeedCapParams
            calls = 0

            def score(self, data: CriticData) -> None:
                if not self.params.enabled:
                    return
                excess = np.maximum(data.controls[0] - self.params.max_speed, 0.0)
                data.costs += self.params.cost_weight * data.model_dt * excess.sum(axis=0)
                self.calls += 1

        yield SimpleNamespace(ViaPointPlanner=ViaPointPlanner, KeepOffLayer=KeepOffLayer,
                              SpeedCapCritic=SpeedCapCritic,
                              MPPISpeedCapCritic=MPPISpeedCapCritic)


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``over`` merged into ``base``; a section naming a ``plugin`` replaces the old one."""
    out = copy.deepcopy(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict) and "plugin" not in value:
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def _files(tmp: Path, *overlays: str, base: dict[str, Any] | None = None) -> tuple[Path, Path]:
    params = base if base is not None else yaml.safe_load(default_nav2_params_path().read_text())
    for text in overlays:
        params = _merge(params, yaml.safe_load(text))
    nav2 = tmp / "nav2_params.yaml"
    nav2.write_text(yaml.safe_dump(params))
    world = tmp / "room.yaml"
    world.write_text(WORLD)
    return nav2, world


def _drive(stack: NavStack, limit_s: float, on_step: Callable[[], None] = lambda: None
           ) -> tuple[TaskResult, np.ndarray, np.ndarray]:
    """Navigate START -> GOAL; ``(result, robot xy per step, commanded vx per step)``."""
    nav = Navigator(stack)
    assert nav.goToPose(PoseStamped.from_pose2d(GOAL, "map", stack.now))
    xy, vx = [], []
    t0 = stack.now
    while not nav.isTaskComplete():
        assert stack.now - t0 < limit_s, "navigation did not end in time"
        p = nav.robot_pose()
        xy.append((p.x, p.y))
        vx.append(stack.controller.last_cmd.vx)
        on_step()
    return nav.getResult(), np.array(xy), np.array(vx)


def _inside(xy: np.ndarray, margin: float = 0.0) -> np.ndarray:
    x0, y0, x1, y1 = ZONE
    return ((xy[:, 0] >= x0 - margin) & (xy[:, 0] <= x1 + margin)
            & (xy[:, 1] >= y0 - margin) & (xy[:, 1] <= y1 + margin))


def test_planner_layer_and_dwb_critic_from_nav2_yaml(my_pkg: SimpleNamespace,
                                                     tmp_path: Path) -> None:
    nav2, world = _files(tmp_path, OVERLAY, DWB_OVERLAY)
    stack = NavStack(str(world), nav2_params=nav2, seed=0).start()
    planner = stack.planner.planners["GridBased"]
    layer = stack.global_costmap.layered.layer("keep_off")
    shim = stack.controller.controllers["FollowPath"]  # the diff-drive default wraps DWB
    dwb = getattr(shim, "primary", shim)
    critic = next(c for c in dwb.critics if c.name == "SpeedCap")
    # built from the YAML by type string, with the YAML's parameters
    assert isinstance(planner, my_pkg.ViaPointPlanner)
    assert planner.params.via_points == [VIA]
    assert isinstance(layer, my_pkg.KeepOffLayer) and layer.params.zone == ZONE
    assert isinstance(critic, my_pkg.SpeedCapCritic) and critic.params.max_speed == 0.2

    # the layer's cost is in the global costmap: every cell centre of the zone is lethal
    cm = stack.global_costmap.costmap
    i0, j0 = cm.world_to_map(ZONE[0] + 0.03, ZONE[1] + 0.03) or (-1, -1)
    i1, j1 = cm.world_to_map(ZONE[2] - 0.03, ZONE[3] - 0.03) or (-1, -1)
    assert (cm.data[j0:j1 + 1, i0:i1 + 1] == LETHAL_OBSTACLE).all()

    rejected: list[int] = []

    def count_rejections() -> None:
        if dwb.last_evaluation is not None:
            rejected.append(dwb.last_evaluation.rejection_counts().get(
                ("SpeedCap", "faster than max_speed"), 0))

    result, xy, vx = _drive(stack, 120.0, count_rejections)
    assert result is TaskResult.SUCCEEDED
    assert math.hypot(*(xy[-1] - (GOAL.x, GOAL.y))) <= 0.3
    assert stack.sim.sim.collisions == 0
    # the custom planner's path is the one followed: it goes round the zone and through
    # the via point, and so does the robot, where the shortest path does not go
    assert planner.plans and stack.planner.last_path is planner.plans[-1]
    path = planner.plans[0].as_array()[:, :2]
    assert not _inside(path).any()
    assert np.hypot(*(path - VIA).T).min() < 0.05
    shortest = NavfnPlanner().plan(START, GOAL, cm).as_array()[:, :2]
    assert np.hypot(*(shortest - VIA).T).min() > 1.0
    assert np.hypot(*(xy - VIA).T).min() < 0.3
    assert not _inside(xy).any()
    beside = xy[(xy[:, 0] > ZONE[0]) & (xy[:, 0] < ZONE[2])]
    assert len(beside) and beside[:, 1].max() < ZONE[1]  # passed south of the zone
    # the DWB critic changed the choice: on most cycles it rejected faster samples, and
    # every command kept to its cap although DWB's max_vel_x is 0.5 m/s
    assert dwb.params.max_vel_x == 0.5
    assert vx.max() <= 0.2 + 1e-9
    assert np.mean(np.array(rejected) > 0) > 0.5


def test_mppi_critic_from_nav2_yaml(my_pkg: SimpleNamespace, tmp_path: Path) -> None:
    from navstack.benchmarks.navigation import nav2_params_for

    nav2, world = _files(tmp_path, OVERLAY, MPPI_OVERLAY, base=nav2_params_for("mppi"))
    stack = NavStack(str(world), nav2_params=nav2, seed=0).start()
    shim = stack.controller.controllers["FollowPath"]  # the diff-drive default wraps MPPI
    mppi = getattr(shim, "primary", shim)
    critic = mppi.optimizer.critics[-1]
    assert isinstance(critic, my_pkg.MPPISpeedCapCritic)
    assert (critic.name, critic.params.max_speed, critic.params.cost_weight) == (
        "SpeedCapCritic", 0.2, 50.0)
    assert mppi.params.critics[-1] == "SpeedCapCritic" and mppi.params.vx_max == 0.5
    result, xy, vx = _drive(stack, 120.0)
    assert result is TaskResult.SUCCEEDED
    assert stack.sim.sim.collisions == 0
    assert critic.calls >= len(vx) // 2
    # MPPI's vx_max is 0.5 m/s (reached in this room without the critic); the critic keeps
    # every command under its cap
    assert vx.max() <= 0.2
    assert np.hypot(*(xy - VIA).T).min() < 0.3  # the custom planner's path, again


DOC = Path(__file__).resolve().parents[1] / "docs" / "extending.md"


def test_extending_doc_examples_register_and_load() -> None:
    """Every Python block of docs/extending.md runs, is under 40 lines, and registers the
    plugin its YAML blocks name; the planner and the layer also work on a costmap."""
    import re

    from navstack.costmap.layered_costmap import LayeredCostmap

    text = DOC.read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 4
    with scoped(PLANNERS, COSTMAP_LAYERS, DWB_CRITICS, MPPI_CRITICS):
        spaces = []
        for code in blocks:
            assert len(code.splitlines()) < 40
            ns: dict[str, Any] = {"__name__": "my_pkg.plugins"}
            exec(compile(code, str(DOC), "exec"), ns)
            spaces.append(ns)
        planner_cls = PLANNERS.get("my_pkg::ViaPointPlanner")
        assert planner_cls is spaces[0]["ViaPointPlanner"]
        assert COSTMAP_LAYERS.get("my_pkg/KeepOffLayer") is spaces[1]["KeepOffLayer"]
        assert DWB_CRITICS.get("my_pkg::SpeedCapCritic") is spaces[2]["SpeedCapCritic"]
        assert MPPI_CRITICS.get("my_pkg::SpeedCapCritic") is spaces[3]["SpeedCapCritic"]
        for plugin in re.findall(r'(?:plugin|class): "(my_pkg(?:/|::)[^"]+)"', text):
            assert any(plugin in reg for reg in (PLANNERS, COSTMAP_LAYERS, DWB_CRITICS)), plugin

        costmap = LayeredCostmap.from_nav2({
            "width": 6.0, "height": 3.0, "resolution": 0.05, "plugins": ["keep_off"],
            "keep_off": {"plugin": "my_pkg/KeepOffLayer", "zone": [2.0, 0.0, 3.0, 2.2]}})
        costmap.update_map(0.5, 0.5, 0.0)
        cm = costmap.costmap
        assert cm.cost_at_world(2.5, 1.0) == LETHAL_OBSTACLE
        assert cm.cost_at_world(2.5, 2.5) == 0 and cm.cost_at_world(1.5, 1.0) == 0
        planner = planner_cls(planner_cls.params_model.from_mapping(
            {"via_points": [[4.0, 0.5]]}))
        path = planner.plan(Pose2D(0.5, 0.5, 0.0), Pose2D(5.5, 1.5, 0.0), cm).as_array()
        assert np.hypot(path[:, 0] - 4.0, path[:, 1] - 0.5).min() < 0.05
        assert path[:, 1][(path[:, 0] > 2.0) & (path[:, 0] < 3.0)].min() > 2.2  # round the zone

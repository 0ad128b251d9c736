"""Scripted stand-ins for the servers the navigation layer talks to.

All of them run on the runtime's simulated clock: a fake base that integrates /cmd_vel
into TF odom->base_link, a straight-line planner, a controller that teleports the base
along the path (or fails / stalls / creeps), recovery behavior servers and the costmap
services.  They record every call so tests can assert exact sequences and times.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navstack.core.msgs import Path, Pose2D, PoseStamped, Twist
from navstack.core.tf import tf_from_pose2d, tf_to_stamped
from navstack.navigation import messages as m
from navstack.navigation.bt_navigator import BtNavigator, BtNavigatorParams
from navstack.navigation.bt_nodes import distance_remaining, path_xy
from navstack.navigation.trees import NavigateTreeParams
from navstack.runtime.actions import ActionClient, ActionResult, ActionServer, GoalHandle
from navstack.runtime.node import Runtime


class FakeBase:
    """A holonomic-integrating base: ``pose`` (odom frame) written to TF at ``rate`` Hz.

    Published Twists on ``/cmd_vel`` are integrated exactly for constant velocity over
    each step (arc for non-zero yaw rate).  ``map -> odom`` is a static ``map_to_odom``.
    """

    def __init__(self, rt: Runtime, pose: Pose2D | None = None, rate: float = 100.0,
                 map_to_odom: Pose2D | None = None, topic: str = "/cmd_vel") -> None:
        self.rt = rt
        self.pose = pose or Pose2D()
        self.cmd = (0.0, 0.0)
        self.twists: list[tuple[float, Twist]] = []
        self.dt = 1.0 / rate
        rt.tf.add_static("map", "odom", map_to_odom or Pose2D())
        rt.bus.subscribe(topic, Twist, self._on_cmd)
        self._write_tf()
        rt.scheduler.create_timer(self.dt, self._step)

    def _on_cmd(self, msg: Twist) -> None:
        self.twists.append((self.rt.now, msg))
        self.cmd = (msg.linear.x, msg.angular.z)

    def _step(self) -> None:
        v, w = self.cmd
        x, y, th = self.pose.x, self.pose.y, self.pose.theta
        dt = self.dt
        if abs(w) < 1e-12:
            x, y = x + v * dt * math.cos(th), y + v * dt * math.sin(th)
        else:
            r = v / w
            x += r * (math.sin(th + w * dt) - math.sin(th))
            y -= r * (math.cos(th + w * dt) - math.cos(th))
        self.pose = Pose2D(x, y, math.remainder(th + w * dt, 2 * math.pi))
        self._write_tf()

    def teleport(self, pose: Pose2D) -> None:
        self.pose = pose
        self._write_tf()

    def _write_tf(self) -> None:
        self.rt.tf.set_transform(tf_to_stamped(tf_from_pose2d(self.pose), "odom", "base_link",
                                               self.rt.now))


def straight_path(a: Pose2D, b: Pose2D, spacing: float = 0.05, stamp: float = 0.0) -> Path:
    n = max(2, math.ceil(a.distance_to(b) / spacing) + 1)
    xs, ys = np.linspace(a.x, b.x, n), np.linspace(a.y, b.y, n)
    th = np.full(n, math.atan2(b.y - a.y, b.x - a.x))
    return Path.from_array(np.column_stack([xs, ys, th]), "map", stamp)


class FakePlanner:
    """ComputePathToPose: a straight line from ``start`` (or the robot) to the goal after
    ``delay`` seconds, or ``fail = (code, reason)``."""

    def __init__(self, rt: Runtime, base: FakeBase, delay: float = 0.0) -> None:
        self.rt, self.base, self.delay = rt, base, delay
        self.calls: list[tuple[float, m.ComputePathToPoseGoal]] = []
        self.fail: tuple[int, str] | None = None
        ActionServer(rt.bus, m.COMPUTE_PATH_TO_POSE, self._on_goal, lambda h: h.canceled())

    def _on_goal(self, h: GoalHandle[m.ComputePathToPoseGoal]) -> bool:
        self.calls.append((self.rt.now, h.goal))
        h.execute()
        self.rt.scheduler.call_later(self.delay, self._finish, h)
        return True

    def _finish(self, h: GoalHandle[m.ComputePathToPoseGoal]) -> None:
        if h.done:
            return
        if self.fail is not None:
            h.fail(*self.fail)
            return
        start = h.goal.start.to_pose2d() if h.goal.start else self.rt.tf.lookup_pose2d(
            "map", "base_link")
        h.succeed(straight_path(start, h.goal.goal.to_pose2d(), stamp=self.rt.now))


class FakeController:
    """FollowPath.  Modes: ``follow`` moves the base along the path at ``speed`` m/s and
    succeeds at its end; ``fail`` fails ``fail_after`` s after each goal; ``stall`` never
    moves nor ends.  A new goal preempts the running one (it ends CANCELED)."""

    def __init__(self, rt: Runtime, base: FakeBase, mode: str = "follow", speed: float = 1.0,
                 rate: float = 20.0) -> None:
        self.rt, self.base, self.mode, self.speed = rt, base, mode, speed
        self.fail_after = 0.1
        self.fail_code = int(m.ControllerErrorCode.NO_VALID_CONTROL)
        self.fail_msg = "no valid trajectory: all 520 sampled trajectories collide"
        self.goals: list[tuple[float, GoalHandle[m.FollowPathGoal]]] = []
        self.cancels: list[tuple[float, GoalHandle[m.FollowPathGoal]]] = []
        self.active: GoalHandle[m.FollowPathGoal] | None = None
        self._xy = np.zeros((0, 2))
        self.dt = 1.0 / rate
        ActionServer(rt.bus, m.FOLLOW_PATH, self._on_goal, self._on_cancel)
        rt.scheduler.create_timer(self.dt, self._step)

    def _on_goal(self, h: GoalHandle[m.FollowPathGoal]) -> bool:
        if self.active is not None and not self.active.done:
            self.active.canceled(reason="preempted by a new path")
        self.goals.append((self.rt.now, h))
        self.active = h
        self._xy = path_xy(h.goal.path)
        h.execute()
        if self.mode == "fail":
            self.rt.scheduler.call_later(self.fail_after, self._fail, h)
        return True

    def _fail(self, h: GoalHandle[m.FollowPathGoal]) -> None:
        h.fail(self.fail_code, self.fail_msg)

    def _on_cancel(self, h: GoalHandle[m.FollowPathGoal]) -> None:
        self.cancels.append((self.rt.now, h))
        h.canceled()

    def _step(self) -> None:
        h = self.active
        if h is None or h.done or self.mode != "follow":
            return
        xy, pose = self._xy, self.base.pose
        seg = np.hypot(*np.diff(xy, axis=0).T)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        target = distance_remaining(xy, pose.x, pose.y) - self.speed * self.dt
        s = cum[-1] - max(target, 0.0)
        x, y = float(np.interp(s, cum, xy[:, 0])), float(np.interp(s, cum, xy[:, 1]))
        self.base.teleport(Pose2D(x, y, pose.theta))
        if target <= 0.0:
            h.succeed()


@dataclass
class FakeBehaviors:
    """Spin / BackUp / DriveOnHeading servers succeeding after ``duration`` s, Wait after its
    goal time, and the
    clear-costmap and is-path-valid services; every call is appended to ``events``."""

    rt: Runtime
    duration: float = 0.1
    path_valid: Callable[[float], bool] = lambda t: True
    events: list[tuple[str, float]] = field(default_factory=list)
    fail: dict[str, tuple[int, str]] = field(default_factory=dict)
    valid_checks: int = 0

    def __post_init__(self) -> None:
        for name, action in (("spin", m.SPIN), ("backup", m.BACKUP), ("wait", m.WAIT),
                             ("drive_on_heading", m.DRIVE_ON_HEADING)):
            ActionServer(self.rt.bus, action, self._server(name), self._cancel)
        bus = self.rt.bus
        bus.advertise_service(m.CLEAR_GLOBAL_COSTMAP, lambda req: self._log("clear_global"))
        bus.advertise_service(m.CLEAR_LOCAL_COSTMAP, lambda req: self._log("clear_local"))
        bus.advertise_service(m.IS_PATH_VALID, self._is_valid)

    def _log(self, name: str) -> None:
        self.events.append((name, self.rt.now))

    def _is_valid(self, path: Path) -> bool:
        self.valid_checks += 1
        return self.path_valid(self.rt.now)

    def _server(self, name: str) -> Callable[[GoalHandle[Any]], bool]:
        def on_goal(h: GoalHandle[Any]) -> bool:
            self._log(name)
            h.execute()
            duration = h.goal.time if name == "wait" else self.duration
            self.rt.scheduler.call_later(duration, self._end, h, name)
            return True
        return on_goal

    def _end(self, h: GoalHandle[Any], name: str) -> None:
        if name in self.fail:
            h.fail(*self.fail[name])
        else:
            h.succeed()

    def _cancel(self, h: GoalHandle[Any]) -> None:
        self._log("cancel")
        h.canceled()

    def names(self, *keep: str) -> list[str]:
        return [n for n, _ in self.events if not keep or n in keep]


@dataclass
class NavHarness:
    rt: Runtime
    base: FakeBase
    planner: FakePlanner
    controller: FakeController
    behaviors: FakeBehaviors
    nav: BtNavigator
    feedback: list[m.NavigateFeedback] = field(default_factory=list)

    def goal(self, x: float, y: float, theta: float = 0.0, frame: str = "map"
             ) -> GoalHandle[m.NavigateToPoseGoal]:
        client: ActionClient[m.NavigateToPoseGoal] = ActionClient(self.rt.bus, m.NAVIGATE_TO_POSE)
        pose = PoseStamped.from_pose2d(Pose2D(x, y, theta), frame, self.rt.now)
        return client.send_goal(m.NavigateToPoseGoal(pose), feedback_cb=self.feedback.append)

    def run_until_done(self, h: GoalHandle[Any], t_max: float = 200.0) -> ActionResult:
        self.rt.scheduler.run_until(t_max, until=lambda: h.done)
        assert h.result is not None, f"goal still {h.status} at t={self.rt.now}"
        return h.result


def make_harness(tree: NavigateTreeParams | None = None, mode: str = "follow",
                 speed: float = 1.0, map_to_odom: Pose2D | None = None,
                 params: BtNavigatorParams | None = None) -> NavHarness:
    rt = Runtime()
    base = FakeBase(rt, map_to_odom=map_to_odom)
    planner = FakePlanner(rt, base)
    controller = FakeController(rt, base, mode, speed)
    behaviors = FakeBehaviors(rt)
    nav = BtNavigator(rt, params, tree or NavigateTreeParams())
    rt.bring_up()
    return NavHarness(rt, base, planner, controller, behaviors, nav)

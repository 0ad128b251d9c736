"""Reusable mission behaviours (py_trees) on the navigation actions.

Each behaviour is a py_trees ``Behaviour`` bound to a :class:`MissionContext`:

=========================  ================================================================
``NavigateToPose``         a NavigateToPose goal (pose, or a callable giving it); FAILURE
                           carries the navigator's reason
``FollowWaypoints``        the waypoint follower; a missed waypoint fails it with its reason
``Spin`` / ``LookAround``  the spin behaviour (LookAround: a full turn)
``WaitFor``                SUCCESS when a condition holds, FAILURE after ``timeout``
``RememberHome``           store the robot's pose as home (explore_lite's initial pose)
``ReturnHome``             navigate home, retrying (``attempts``), within ``tolerance``
``SaveMap``                slam_toolbox's save_map (map_server YAML + PGM) and
                           serialize_map (pose graph) services
=========================  ================================================================

Action behaviours send their goal in ``initialise`` and cancel it in ``terminate`` when
the tree stops them (a mission cancelled, a parallel branch won), so a cancelled mission
never leaves a goal running; the servers publish a zero velocity when a goal ends.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Generic, TypeVar

from py_trees.behaviour import Behaviour
from py_trees.common import Status

from navstack.core.errors import NavstackError
from navstack.core.msgs import Pose2D, PoseStamped
from navstack.missions.context import MissionContext
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus

G = TypeVar("G")
PoseSource = Pose2D | Callable[[], Pose2D | None]

__all__ = ["ActionBehaviour", "FollowWaypoints", "LookAround", "NavigateToPose",
           "RememberHome", "ReturnHome", "SaveMap", "Spin", "WaitFor"]


class MissionBehaviour(Behaviour):
    """A behaviour with a :class:`MissionContext`."""

    def __init__(self, ctx: MissionContext, name: str) -> None:
        super().__init__(name)
        self.ctx = ctx

    def failed(self, reason: str) -> Status:
        self.ctx.fail(self.name, reason)
        return Status.FAILURE


class ActionBehaviour(MissionBehaviour, ABC, Generic[G]):
    """Sends one action goal per run; SUCCESS/FAILURE from the result, cancel on stop."""

    def __init__(self, ctx: MissionContext, name: str, client: ActionClient[G]) -> None:
        super().__init__(ctx, name)
        self.client = client
        self.handle: GoalHandle[G] | None = None
        self.start_time = 0.0

    @abstractmethod
    def make_goal(self) -> G | str:
        """The goal to send, or a reason why there is none."""

    def initialise(self) -> None:
        self.handle = None
        self.start_time = self.ctx.now
        goal = self.make_goal()
        if isinstance(goal, str):
            self._problem = goal
            return
        self._problem = ""
        try:
            self.handle = self.client.send_goal(goal)
        except NavstackError as exc:
            self._problem = f"cannot send the goal to {self.client.name}: {exc}"

    def update(self) -> Status:
        if self._problem:
            return self.failed(self._problem)
        handle = self.handle
        assert handle is not None
        if handle.status is GoalStatus.REJECTED:
            reason = handle.result.error_msg if handle.result else "rejected"
            return self.failed(f"{self.client.name} rejected the goal: {reason}")
        if not handle.done:
            self.on_running(handle)
            return Status.RUNNING
        result = handle.result
        assert result is not None
        if result.status is GoalStatus.SUCCEEDED:
            return self.on_succeeded(handle)
        return self.failed(f"{result.status.value}: {result.error_msg or 'no reason given'}")

    def on_running(self, handle: GoalHandle[G]) -> None:
        """Called on every tick while the goal runs (feedback)."""

    def on_succeeded(self, handle: GoalHandle[G]) -> Status:
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID and self.handle is not None and not self.handle.done:
            self.handle.cancel()
            self.ctx.stop_robot()


def _resolve(source: PoseSource) -> Pose2D | None:
    return source() if callable(source) else source


class NavigateToPose(ActionBehaviour[m.NavigateToPoseGoal]):
    """Navigate to a pose (given, or computed when the behaviour starts)."""

    def __init__(self, ctx: MissionContext, pose: PoseSource, name: str = "NavigateToPose",
                 behavior_tree: str = "") -> None:
        super().__init__(ctx, name, ctx.navigate_to_pose)
        self.pose = pose
        self.behavior_tree = behavior_tree
        self.target: Pose2D | None = None

    def make_goal(self) -> m.NavigateToPoseGoal | str:
        self.target = _resolve(self.pose)
        if self.target is None:
            return "no goal pose (nothing stored under it yet)"
        t = self.target
        self.ctx.log(f"{self.name}: navigating to ({t.x:.2f}, {t.y:.2f}, {t.theta:.2f})")
        return m.NavigateToPoseGoal(self.ctx.pose_stamped(t), self.behavior_tree)

    def on_running(self, handle: GoalHandle[m.NavigateToPoseGoal]) -> None:
        fb = handle.feedback
        if isinstance(fb, m.NavigateFeedback):
            self.ctx.feedback(f"{self.name}: {fb.distance_remaining:.1f} m to go",
                              distance_remaining=fb.distance_remaining,
                              recoveries=fb.number_of_recoveries)


class FollowWaypoints(ActionBehaviour[m.FollowWaypointsGoal]):
    """Visit waypoints in order with the waypoint follower; a missed one fails it."""

    def __init__(self, ctx: MissionContext, poses: Sequence[Pose2D],
                 names: Sequence[str] = (), name: str = "FollowWaypoints") -> None:
        super().__init__(ctx, name, ctx.follow_waypoints)
        self.poses = list(poses)
        self.names = list(names)

    def make_goal(self) -> m.FollowWaypointsGoal | str:
        if not self.poses:
            return "no waypoints given"
        return m.FollowWaypointsGoal(tuple(self.ctx.pose_stamped(p) for p in self.poses),
                                     tuple(self.names))

    def on_running(self, handle: GoalHandle[m.FollowWaypointsGoal]) -> None:
        fb = handle.feedback
        if isinstance(fb, m.FollowWaypointsFeedback):
            label = fb.current_waypoint_name or f"#{fb.current_waypoint}"
            self.ctx.feedback(f"{self.name}: waypoint {label} "
                              f"({fb.current_waypoint + 1}/{len(self.poses)})",
                              waypoint=fb.current_waypoint)

    def on_succeeded(self, handle: GoalHandle[m.FollowWaypointsGoal]) -> Status:
        result = handle.result.result if handle.result is not None else None
        missed = getattr(result, "missed_waypoints", ())
        if missed:
            detail = "; ".join(f"{w.name or w.index}: {w.error_msg}" for w in missed)
            return self.failed(f"missed {len(missed)} of {len(self.poses)} waypoints: {detail}")
        return Status.SUCCESS


class Spin(ActionBehaviour[m.SpinGoal]):
    """Turn in place by ``angle`` [rad] (sign = direction) with the spin behaviour."""

    def __init__(self, ctx: MissionContext, angle: float, name: str = "Spin",
                 time_allowance: float = 20.0) -> None:
        super().__init__(ctx, name, ctx.spin)
        self.angle = angle
        self.time_allowance = time_allowance

    def make_goal(self) -> m.SpinGoal:
        return m.SpinGoal(self.angle, self.time_allowance)


class LookAround(Spin):
    """A full turn in place (a 360 degree look with a forward-looking sensor)."""

    def __init__(self, ctx: MissionContext, name: str = "LookAround") -> None:
        super().__init__(ctx, 2.0 * math.pi, name, time_allowance=30.0)


class WaitFor(MissionBehaviour):
    """SUCCESS once ``condition()`` holds; FAILURE after ``timeout`` seconds."""

    def __init__(self, ctx: MissionContext, condition: Callable[[], bool], timeout: float,
                 description: str, name: str = "WaitFor") -> None:
        super().__init__(ctx, name)
        self.condition = condition
        self.timeout = timeout
        self.description = description
        self.start = 0.0

    def initialise(self) -> None:
        self.start = self.ctx.now

    def update(self) -> Status:
        if self.condition():
            return Status.SUCCESS
        if self.ctx.now - self.start > self.timeout:
            return self.failed(f"{self.description} did not happen within {self.timeout:.0f} s")
        self.ctx.feedback(f"{self.name}: waiting for {self.description}")
        return Status.RUNNING


class RememberHome(MissionBehaviour):
    """Store the robot's current pose as ``ctx.results[key]`` (the return-home goal);
    waits up to ``timeout`` [s] for TF to know it (SLAM publishes ``map -> odom`` after
    its first scan)."""

    def __init__(self, ctx: MissionContext, key: str = "home", timeout: float = 10.0,
                 name: str = "RememberHome") -> None:
        super().__init__(ctx, name)
        self.key = key
        self.timeout = timeout
        self.start = 0.0

    def initialise(self) -> None:
        self.start = self.ctx.now

    def update(self) -> Status:
        pose = self.ctx.robot_pose()
        if pose is None:
            if self.ctx.now - self.start <= self.timeout:
                return Status.RUNNING
            return self.failed(f"no robot pose: TF has no {self.ctx.global_frame} -> "
                               f"{self.ctx.base_frame} after {self.timeout:.0f} s")
        self.ctx.results[self.key] = pose
        self.ctx.log(f"home is ({pose.x:.2f}, {pose.y:.2f}, {pose.theta:.2f})")
        return Status.SUCCESS


class ReturnHome(MissionBehaviour):
    """Navigate to the stored home pose and check the robot ended within ``tolerance`` [m]
    of it; up to ``attempts`` goals (explore_lite's ``return_to_init`` sends one goal and
    never checks it).

    Home is a position first: when the navigator cannot finish (the final turn to the
    home heading next to a wall, a last few centimetres it cannot make up) and the robot
    has come no closer for ``settle_time`` [s], the goal is cancelled.  Within
    ``precise`` [m] that is success; otherwise the next attempt asks for the heading the
    robot arrives with (no final turn), and after the last attempt anything within
    ``tolerance`` is success -- each logged with the reason.  A goal the navigator
    reached (its goal checker passed) is success within ``tolerance``: the checker's own
    tolerance may exceed ``precise`` by the localisation noise.

    ``between``: a behaviour run before each retry (e.g. exploration's ``Escape``: a
    robot the controller refused to move -- "collision ahead" on every arc out of a
    tight spot -- is first moved to where it can turn); its outcome does not fail the
    return home.

    ``relocalise``: a behaviour run once on the first arrival (e.g. :class:`LookAround`):
    with SLAM the pose is an estimate, and a robot that drove back along a path seen
    minutes ago arrives with the drift of that drive (0.2-0.4 m after 20 m in the
    warehouse, issue 16); a full turn at home gives the mapper scans of the start's
    surroundings from every side -- the loop closures that correct the estimate.  The
    distance is then judged again and, beyond ``precise``, the robot drives back to
    where home now is.  Its outcome does not fail the return home either."""

    def __init__(self, ctx: MissionContext, key: str = "home", attempts: int = 3,
                 tolerance: float = 0.3, settle_time: float = 5.0, precise: float = 0.2,
                 name: str = "ReturnHome", between: Behaviour | None = None,
                 relocalise: Behaviour | None = None) -> None:
        super().__init__(ctx, name)
        self.key = key
        self.attempts = attempts
        self.tolerance = tolerance
        self.settle_time = settle_time
        self.precise = min(precise, tolerance)
        self._best = (math.inf, 0.0)
        self.nav = NavigateToPose(ctx, self._goal, name=name)
        self.tries = 0
        self.reasons: list[str] = []
        self.failures_before = 0
        self.between = between
        self._recovering = False
        self.relocalise = relocalise
        self._relocalising = False
        self._relocalised = False

    def _home(self) -> Pose2D | None:
        home = self.ctx.results.get(self.key)
        return home if isinstance(home, Pose2D) else None

    def _goal(self) -> Pose2D | None:
        home = self._home()
        pose = self.ctx.robot_pose()
        if home is None or self.tries == 0 or pose is None:
            return home
        if math.hypot(home.x - pose.x, home.y - pose.y) < 1e-3:
            return home
        # a retry arrives with the heading it drives in: no final turn
        return Pose2D(home.x, home.y, math.atan2(home.y - pose.y, home.x - pose.x))

    def initialise(self) -> None:
        self.tries = 0
        self.reasons = []
        self.nav.stop(Status.INVALID)
        self.failures_before = len(self.ctx.failures)
        self._best = (math.inf, self.ctx.now)
        self._recovering = False
        self._relocalising = False
        self._relocalised = False

    def _settled(self, dist: float) -> bool:
        """Within tolerance and no closer for ``settle_time``."""
        now = self.ctx.now
        if dist < self._best[0] - 0.02:
            self._best = (dist, now)
        return dist <= self.tolerance and now - self._best[1] >= self.settle_time

    def _accept(self, dist: float, reached: bool) -> bool:
        """A goal the navigator reached (its goal checker's tolerance, e.g. 0.15 m) counts
        within ``tolerance``; an unfinished one within ``precise``, or ``tolerance`` on the
        last attempt."""
        last = self.tries + 1 >= self.attempts
        return dist <= (self.tolerance if last or reached else self.precise)

    def update(self) -> Status:
        home = self._home()
        if home is None:
            return self.failed(f"no home pose stored under '{self.key}' (RememberHome first)")
        if self._recovering and self.between is not None:
            self.between.tick_once()
            if self.between.status is Status.RUNNING:
                return Status.RUNNING
            del self.ctx.failures[self.failures_before:]  # best effort
            self._recovering = False
            self._best = (math.inf, self.ctx.now)
        if self._relocalising:
            return self._after_relocalise()
        self.nav.tick_once()
        status = self.nav.status
        pose = self.ctx.robot_pose()
        dist = math.hypot(pose.x - home.x, pose.y - home.y) if pose is not None else math.inf
        why = ""
        if status is Status.RUNNING:
            if not self._settled(dist):
                return Status.RUNNING
            self.nav.stop(Status.INVALID)
            why = f"stopped {dist:.2f} m from home: no closer for {self.settle_time:.0f} s"
        elif status is Status.FAILURE and self.ctx.failures:
            why = self.ctx.failures[-1].reason
        if self._accept(dist, status is Status.SUCCESS):
            if self.relocalise is not None and not self._relocalised:
                self.ctx.log(f"{self.name}: at home within {dist:.2f} m (estimate); "
                             f"{self.relocalise.name} before judging it")
                self.nav.stop(Status.INVALID)
                self.relocalise.stop(Status.INVALID)
                self._relocalising = True
                return Status.RUNNING
            return self._arrived(dist, f" (the navigator ended {why})" if why else "")
        self.tries += 1
        self.reasons.append(why or f"ended {dist:.2f} m from home "
                                   f"(tolerance {self.tolerance:.2f} m)")
        if self.tries >= self.attempts:
            del self.ctx.failures[self.failures_before:]
            return self.failed(f"could not return home in {self.attempts} attempts: "
                               + " | ".join(self.reasons))
        self.ctx.log(f"{self.name}: attempt {self.tries} failed ({self.reasons[-1]}); "
                     f"trying again")
        self.nav.stop(Status.INVALID)
        self._best = (math.inf, self.ctx.now)
        if self.between is not None:
            self.between.stop(Status.INVALID)
            self._recovering = True
        return Status.RUNNING

    def _arrived(self, dist: float, note: str) -> Status:
        del self.ctx.failures[self.failures_before:]  # earlier attempts' failures healed
        self.ctx.results[f"{self.key}_distance"] = dist
        self.ctx.log(f"{self.name}: home within {dist:.2f} m after {self.tries + 1} "
                     f"goal(s){note}")
        return Status.SUCCESS

    def _after_relocalise(self) -> Status:
        """Tick the relocalising behaviour; when it ends, judge the distance again from
        the (possibly corrected) estimate, and drive back if home has moved away."""
        assert self.relocalise is not None
        self.relocalise.tick_once()
        if self.relocalise.status is Status.RUNNING:
            return Status.RUNNING
        del self.ctx.failures[self.failures_before:]  # best effort
        self._relocalising = False
        self._relocalised = True
        home, pose = self._home(), self.ctx.robot_pose()
        dist = math.hypot(pose.x - home.x, pose.y - home.y) \
            if pose is not None and home is not None else math.inf
        if dist <= self.precise:
            return self._arrived(dist, f" (still within {self.precise:.2f} m after "
                                       f"{self.relocalise.name})")
        self.ctx.log(f"{self.name}: after {self.relocalise.name} home is {dist:.2f} m "
                     f"away; driving back")
        self.nav.stop(Status.INVALID)
        self._best = (math.inf, self.ctx.now)
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID:
            self.nav.stop(Status.INVALID)
            for child in (self.between, self.relocalise):
                if child is not None and child.status is Status.RUNNING:
                    child.stop(Status.INVALID)


class SaveMap(MissionBehaviour):
    """Save the SLAM map: ``/slam_toolbox/save_map`` (map_server YAML + PGM at ``path``)
    and ``/slam_toolbox/serialize_map`` (the pose graph, ``path.posegraph``)."""

    def __init__(self, ctx: MissionContext, path: str, slam_node: str = "slam_toolbox",
                 serialize: bool = True, name: str = "SaveMap") -> None:
        super().__init__(ctx, name)
        self.path = path
        self.slam_node = slam_node
        self.serialize = serialize

    def update(self) -> Status:
        prefix = f"/{self.slam_node}"
        try:
            saved: dict[str, Any] = self.ctx.call(f"{prefix}/save_map", {"name": self.path})
            if not saved.get("result"):
                return self.failed(f"save_map failed: {saved.get('reason', 'no reason')}")
            # the service answers with the image it wrote; the YAML sits beside it
            image = Path(str(saved["path"]))
            files = {"map_yaml": str(image.with_suffix(".yaml")), "map_image": str(image)}
            if self.serialize:
                graph: dict[str, Any] = self.ctx.call(f"{prefix}/serialize_map",
                                                      {"filename": self.path})
                if not graph.get("result"):
                    return self.failed(f"serialize_map failed: {graph.get('reason')}")
                files["posegraph"] = str(graph["path"])
        except NavstackError as exc:
            return self.failed(f"cannot save the map: {exc}")
        self.ctx.results["saved_map"] = files
        self.ctx.log(f"map saved: {', '.join(files.values())}")
        return Status.SUCCESS


def goal_pose(ps: PoseStamped) -> Pose2D:
    """``PoseStamped`` -> ``Pose2D`` (helper for user missions)."""
    return ps.to_pose2d()

"""``BehaviorServer``: the recovery behavior actions (Nav2 ``nav2_behaviors``,
``TimedBehavior`` semantics), one action per behavior plugin.

``behavior_plugins`` names the behaviors (default: ``spin``, ``backup``,
``drive_on_heading``, ``wait``); each serves the action ``/<name>`` with the
:class:`~navstack.core.interfaces.Behavior` plugin its section names (``spin: {plugin:
"nav2_behaviors/Spin"}``; the four default names default to Nav2's types).  The built-in
behaviors are in :mod:`navstack.navigation.behaviors`.

Each accepted goal runs from a timer at ``cycle_frequency``.  Every cycle reads the
robot pose ``local_frame -> robot_base_frame`` from TF (older than
``transform_tolerance`` -> ``TF_ERROR``), checks the goal's time allowance (0 =
unlimited; exceeded -> ``TIMEOUT``), publishes ``BehaviorFeedback`` and a Twist on
``cmd_vel_topic``.  Before a motion command is published the motion is projected ahead
in steps of ``1 / cycle_frequency`` for ``simulate_ahead_time`` seconds (stopping where
the behavior would end) and each projected pose is passed to ``collision_checker``; a
hit stops the robot and fails with ``COLLISION_AHEAD`` naming the pose.  The current
pose itself is not checked, so a robot touching an obstacle can still back away from
it.  navstack: with a ``penetration(pose)`` function (the stack wires
:func:`navstack.costmap.footprint_penetration.penetration_depth` on the local costmap),
a robot whose footprint already reaches into lethal cells -- SLAM drift moved a wall, a
cell bloats an obstacle edge -- may make any motion that goes no deeper than it is
(``escape_penetration_tolerance``): it drives along or away from the obstacle instead
of refusing every command.  Whatever the outcome, a zero Twist is published when a behavior ends.

Deviation: ``cycle_frequency`` defaults to 20 Hz (Nav2: 10 Hz), the controller rate,
which halves the overshoot of the last cycle.  A new goal to any behavior preempts the
running one (it ends CANCELED, "preempted by a new goal").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, SerializeAsAny, field_validator

from navstack.core.errors import InvalidBehaviorGoal, TransformError
from navstack.core.interfaces import Behavior
from navstack.core.msgs import Pose2D, Twist, Twist2D
from navstack.core.params import Params
from navstack.core.plugins import BEHAVIORS
from navstack.navigation import messages as m
from navstack.navigation.plugins import load_plugin, plugin_section
from navstack.runtime.actions import ActionServer, GoalHandle
from navstack.runtime.node import LifecycleState, Node, Runtime
from navstack.runtime.scheduler import Timer

CollisionChecker = Callable[[Pose2D], bool]
"""True when the robot footprint at this ``local_frame`` pose is in collision."""
BehaviorCode = m.BehaviorErrorCode

DEFAULT_BEHAVIOR_TYPES: dict[str, str] = {
    "spin": "nav2_behaviors::Spin", "backup": "nav2_behaviors::BackUp",
    "drive_on_heading": "nav2_behaviors::DriveOnHeading", "wait": "nav2_behaviors::Wait"}
"""Nav2's default behavior names and the type each defaults to."""


class BehaviorSpec(Params):
    """One configured behavior: its plugin type string and its validated parameters."""

    plugin: str
    params: SerializeAsAny[Params]


class BehaviorServerParams(Params):
    """Nav2 ``behavior_server`` parameters (Nav2 names and defaults, except
    ``cycle_frequency``); ``cmd_vel_topic`` is where the Twists go.

    Spin's limits are server-level keys, as in Nav2; ``behaviors`` holds each listed
    behavior's plugin type and parameters (built by :meth:`from_mapping` from the
    behavior sections, or with the defaults by :meth:`behavior_spec`).
    """

    cycle_frequency: float = Field(20.0, gt=0.0)
    local_frame: str = "odom"
    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    transform_tolerance: float = Field(0.1, gt=0.0)
    simulate_ahead_time: float = Field(2.0, ge=0.0)
    max_rotational_vel: float = Field(1.0, gt=0.0)
    min_rotational_vel: float = Field(0.4, ge=0.0)
    rotational_acc_lim: float = Field(3.2, gt=0.0)
    cmd_vel_topic: str = "/cmd_vel"
    behavior_plugins: list[str] = Field(default_factory=lambda: list(DEFAULT_BEHAVIOR_TYPES))
    behaviors: dict[str, BehaviorSpec] = Field(default_factory=dict)
    # navstack: a motion starting with the footprint in lethal cells is refused only when
    # it reaches deeper than this beyond the start's depth [m] (module docstring)
    escape_penetration_tolerance: float = Field(0.005, ge=0.0)

    @field_validator("behavior_plugins")
    @classmethod
    def _unique(cls, names: list[str]) -> list[str]:
        if len(set(names)) != len(names):
            raise ValueError(f"lists a behavior twice: {names}")
        return names

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Validate a Nav2 ``behavior_server`` section, behavior sections included."""
        flat = dict(data or {})
        listed = flat.get("behavior_plugins", list(DEFAULT_BEHAVIOR_TYPES))
        sections = {name: flat.pop(name) for name in (listed if isinstance(listed, list) else [])
                    if isinstance(name, str) and name in flat and name not in cls.model_fields}
        server = super().from_mapping(flat, file=file, key_path=key_path)
        specs = {name: server.behavior_spec(name, sections, file=file, key_path=key_path)
                 for name in server.behavior_plugins}
        return server.model_copy(update={"behaviors": specs})

    def behavior_spec(self, name: str, sections: Mapping[str, Any] | None = None, *,
                      file: str = "", key_path: str = "") -> BehaviorSpec:
        """The spec of behavior ``name`` from its section in ``sections`` (plugin type and
        overrides; default type for Nav2's default names) and the server-level values of
        the keys its params model declares."""
        where = f"{key_path}.{name}" if key_path else name
        plugin, section = plugin_section(sections or {}, name, DEFAULT_BEHAVIOR_TYPES.get(name),
                                         file=file, key_path=key_path)
        cls = load_plugin(BEHAVIORS, plugin, file=file, key_path=where)
        model = cls.params_model
        inherited = {k: getattr(self, k) for k in model.model_fields
                     if k in type(self).model_fields}
        return BehaviorSpec(plugin=plugin, params=model.from_mapping(
            {**inherited, **section}, file=file, key_path=where))


@dataclass
class _Active:
    kind: str
    handle: GoalHandle[Any]
    behavior: Behavior[Any]
    start: float
    timer: Timer | None = None


class _TfError(Exception):
    """The robot pose cannot be read from TF (-> TF_ERROR)."""


def _fmt(p: Pose2D | NDArray[np.float64]) -> str:
    x, y, th = (p.x, p.y, p.theta) if isinstance(p, Pose2D) else (p[0], p[1], p[2])
    return f"(x={x:.2f}, y={y:.2f}, yaw={th:.2f})"


@dataclass(frozen=True)
class BehaviorResult:
    """Result payload (Nav2 ``total_elapsed_time``) plus the final progress value."""

    total_elapsed_time: float
    progress: float


class BehaviorServer(Node):
    """Spin, BackUp, DriveOnHeading and Wait action servers publishing on ``cmd_vel_topic``.

    ``collision_checker(pose)`` says whether the footprint at an odom-frame pose collides
    (the stack wires it to the local costmap); ``None`` disables collision checking.
    """

    def __init__(self, runtime: Runtime, params: BehaviorServerParams | None = None,
                 collision_checker: CollisionChecker | None = None,
                 name: str = "behavior_server",
                 penetration: Callable[[Pose2D], float] | None = None) -> None:
        super().__init__(name, runtime)
        self.params = params or BehaviorServerParams()
        self.collision_checker = collision_checker
        self.penetration = penetration
        self.behaviors: dict[str, Behavior[Any]] = {}
        """The behavior plugins by name; each serves the action ``/<name>``."""
        for bname in self.params.behavior_plugins:
            spec = self.params.behaviors.get(bname) or self.params.behavior_spec(
                bname, key_path=name)
            cls = load_plugin(BEHAVIORS, spec.plugin, key_path=f"{name}.{bname}")
            self.behaviors[bname] = cls(spec.params)
        self._servers: list[ActionServer[Any]] = []
        self._active: _Active | None = None
        n = int(self.params.cycle_frequency * self.params.simulate_ahead_time + 1e-9)
        self._steps = np.arange(1, n + 1) / self.params.cycle_frequency

    def on_configure(self) -> None:
        self._pub = self.create_publisher(self.params.cmd_vel_topic, Twist)
        for kind in self.behaviors:
            self._servers.append(ActionServer(self.bus, f"/{kind}", self._goal_handler(kind),
                                              self._on_cancel))

    def on_deactivate(self) -> None:
        if self._active is not None:
            self._end(self._active, "canceled", reason=f"{self.name} was deactivated")

    def on_cleanup(self) -> None:
        for server in self._servers:
            server.close()
        self._servers.clear()

    @property
    def active_behavior(self) -> str | None:
        return self._active.kind if self._active is not None else None

    # --- goals -----------------------------------------------------------------------
    def _robot_pose(self) -> Pose2D:
        local, base = self.params.local_frame, self.params.robot_base_frame
        try:
            ts = self.tf.lookup(local, base)
        except TransformError as exc:
            raise _TfError(f"robot pose ({base} in {local}) is not available: {exc}") from None
        age = self.now - ts.header.stamp
        if age > self.params.transform_tolerance:
            raise _TfError(f"robot pose ({base} in {local}) is {age:.2f} s old "
                           f"(transform_tolerance {self.params.transform_tolerance:g} s); "
                           f"is odometry running?")
        return ts.transform.to_pose2d()

    def _goal_handler(self, kind: str) -> Callable[[GoalHandle[Any]], bool | str]:
        def on_goal(handle: GoalHandle[Any]) -> bool | str:
            if self.state is not LifecycleState.ACTIVE:
                return f"{self.name} is not active (state {self.state.value}); activate it first"
            handle.execute()
            behavior = self.behaviors[kind]
            if not isinstance(handle.goal, behavior.goal_type):
                handle.fail(int(BehaviorCode.INVALID_INPUT),
                            f"{kind}: expects a {behavior.goal_type.__name__}, got "
                            f"{type(handle.goal).__name__}")
                return True
            try:
                behavior.start(handle.goal, self._robot_pose(), self.now)
            except _TfError as exc:
                handle.fail(int(BehaviorCode.TF_ERROR), f"{kind}: {exc}")
                return True
            except InvalidBehaviorGoal as exc:
                handle.fail(int(BehaviorCode.INVALID_INPUT), f"{kind}: {exc}")
                return True
            if self._active is not None:
                self._end(self._active, "canceled", reason="preempted by a new goal")
            act = _Active(kind, handle, behavior, self.now)
            self._active = act
            act.timer = self.runtime.scheduler.create_timer(
                1.0 / self.params.cycle_frequency, self._cycle, first_at=self.now)
            return True
        return on_goal

    def _on_cancel(self, handle: GoalHandle[Any]) -> None:
        act = self._active
        if act is not None and act.handle is handle:
            self._end(act, "canceled")
        else:
            handle.canceled()

    def _end(self, act: _Active, outcome: str, code: int = 0, reason: str = "",
             progress: float = 0.0) -> None:
        if act.timer is not None:
            act.timer.cancel()
        if self._active is act:
            self._active = None
        self._pub.publish(Twist())
        result = BehaviorResult(self.now - act.start, progress)
        if outcome == "succeeded":
            act.handle.succeed(result)
        elif outcome == "failed":
            act.handle.fail(code, reason, result)
        else:
            act.handle.canceled(result, reason=reason or "canceled on request")

    # --- cycle -------------------------------------------------------------------------
    def _cycle(self) -> None:
        act = self._active
        if act is None or act.handle.done:
            return
        b = act.behavior
        elapsed = self.now - act.start
        if b.time_allowance > 0.0 and elapsed > b.time_allowance:
            self._end(act, "failed", int(BehaviorCode.TIMEOUT),
                      f"{act.kind}: {b.description} did not finish within time_allowance "
                      f"{b.time_allowance:g} s", b.progress)
            return
        try:
            pose = self._robot_pose()
        except _TfError as exc:
            self._end(act, "failed", int(BehaviorCode.TF_ERROR), f"{act.kind}: {exc}",
                      b.progress)
            return
        step = b.cycle(pose, self.now)
        act.handle.publish_feedback(m.BehaviorFeedback(step.progress))
        if step.done:
            self._end(act, "succeeded", progress=step.progress)
            return
        if step.twist is None:
            return
        hit = self._collision_ahead(b, pose, step.twist)
        if hit is not None:
            self._end(act, "failed", int(BehaviorCode.COLLISION_AHEAD),
                      f"{act.kind}: collision ahead: {b.description} would put the footprint in "
                      f"collision at {self.params.local_frame} pose {_fmt(hit)} within "
                      f"simulate_ahead_time {self.params.simulate_ahead_time:g} s; stopped at "
                      f"{_fmt(pose)}", step.progress)
            return
        self._pub.publish(step.twist.to_twist())

    def _collision_ahead(self, b: Behavior[Any], pose: Pose2D, twist: Twist2D
                         ) -> NDArray[np.float64] | None:
        if self.collision_checker is None:
            return None
        rows = b.projection(pose, twist, self._steps)
        if self.penetration is not None and self.collision_checker(pose):
            # already overlapping lethal cells: allow what goes no deeper (escape rule)
            limit = self.penetration(pose) + self.params.escape_penetration_tolerance
            for row in rows:
                if self.penetration(Pose2D(float(row[0]), float(row[1]), float(row[2]))) > limit:
                    return row
            return None
        for row in rows:
            if self.collision_checker(Pose2D(float(row[0]), float(row[1]), float(row[2]))):
                return row
        return None


"""``MissionContext``: what mission behaviours use to act on a running robot.

A mission talks to the robot only through the bus, exactly as a Nav2 script talks to
Nav2 through actions, topics and services -- so the same mission runs on the simulator
and on a real robot.  The context gives the behaviours:

* the clock (``now``) and the robot pose from TF (``global_frame`` <- ``base_frame``);
* action clients of the navigation servers: ``/navigate_to_pose``,
  ``/follow_waypoints``, ``/spin``, ``/backup``, ``/drive_on_heading``, ``/wait``
  (the actions nav2_simple_commander's ``BasicNavigator`` sends; navstack's
  :class:`~navstack.interfaces.api.Navigator` is that API for scripts, the context is
  the same thing for behaviour trees, which sit below the interfaces layer);
* services (``call``), latest messages of topics (``latest``), publishers;
* the mission's record: ``log`` (timestamped events), ``feedback`` (what the mission is
  doing now, with numbers for progress), ``fail`` (why a behaviour failed -- the
  mission's result reason), ``results`` (data a behaviour hands to the report).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from navstack.core.errors import TransformError
from navstack.core.msgs import Bool, Pose2D, PoseStamped, Twist
from navstack.navigation import messages as m
from navstack.navigation.velocity_smoother_node import STOP_TOPIC
from navstack.runtime.actions import ActionClient
from navstack.runtime.bus import DEFAULT_QOS, QoS, Subscription
from navstack.runtime.node import Runtime

M = TypeVar("M")

__all__ = ["FailureRecord", "MissionContext"]


@dataclass(frozen=True)
class FailureRecord:
    """Why a behaviour failed: its name, a sentence, and when."""

    behaviour: str
    reason: str
    stamp: float

    def describe(self) -> str:
        return f"{self.behaviour}: {self.reason}"


@dataclass
class MissionContext:
    """The mission's handle on the robot (module docstring)."""

    runtime: Runtime
    global_frame: str = "map"
    base_frame: str = "base_link"
    cmd_vel_topic: str = "/cmd_vel_nav"
    events: list[tuple[float, str]] = field(default_factory=list)
    failures: list[FailureRecord] = field(default_factory=list)
    results: dict[str, Any] = field(default_factory=dict)
    status_text: str = ""
    progress: dict[str, float] = field(default_factory=dict)
    listeners: list[Callable[[float, str], None]] = field(default_factory=list)

    def __post_init__(self) -> None:
        bus = self.runtime.bus
        self.navigate_to_pose: ActionClient[m.NavigateToPoseGoal] = ActionClient(
            bus, m.NAVIGATE_TO_POSE)
        self.follow_waypoints: ActionClient[m.FollowWaypointsGoal] = ActionClient(
            bus, m.FOLLOW_WAYPOINTS)
        self.spin: ActionClient[m.SpinGoal] = ActionClient(bus, m.SPIN)
        self.backup: ActionClient[m.BackUpGoal] = ActionClient(bus, m.BACKUP)
        self.drive_on_heading: ActionClient[m.DriveOnHeadingGoal] = ActionClient(
            bus, m.DRIVE_ON_HEADING)
        self.wait: ActionClient[m.WaitGoal] = ActionClient(bus, m.WAIT)
        self._latest: dict[str, Any] = {}
        self._subs: list[Subscription[Any]] = []
        self._cmd = bus.publisher(self.cmd_vel_topic, Twist, QoS(depth=1))
        self._halt = bus.publisher(STOP_TOPIC, Bool, QoS(depth=1))

    # --- the robot -------------------------------------------------------------------------
    @property
    def now(self) -> float:
        return self.runtime.now

    def robot_pose(self) -> Pose2D | None:
        """The robot's pose in ``global_frame`` from TF, ``None`` when TF cannot tell."""
        try:
            return self.runtime.tf.lookup_pose2d(self.global_frame, self.base_frame)
        except TransformError:
            return None

    def pose_stamped(self, pose: Pose2D) -> PoseStamped:
        return PoseStamped.from_pose2d(pose, self.global_frame, self.now)

    def stop_robot(self, at_once: bool = False) -> None:
        """Publish a zero velocity on ``cmd_vel_topic`` (as Nav2 behaviours do on exit);
        ``at_once`` (an operator's cancel) also asks the velocity smoother to stop without
        its deceleration ramp (:data:`~navstack.navigation.velocity_smoother_node.STOP_TOPIC`)."""
        self._cmd.publish(Twist())
        if at_once:
            self._halt.publish(Bool(True))

    # --- bus -------------------------------------------------------------------------------
    def latest(self, topic: str, msg_type: type[M], qos: QoS = DEFAULT_QOS) -> M | None:
        """The newest message on ``topic`` (subscribing on first use; latched topics
        deliver their held message at once)."""
        if topic not in self._latest:
            self._latest[topic] = None

            def keep(msg: M) -> None:
                self._latest[topic] = msg

            self._subs.append(self.runtime.bus.subscribe(topic, msg_type, keep, qos))
        value: M | None = self._latest[topic]
        return value

    def call(self, service: str, request: Any) -> Any:
        """Call a bus service (in-process services answer at once)."""
        return self.runtime.bus.call(service, request)

    def close(self) -> None:
        for sub in self._subs:
            sub.unsubscribe()
        self._subs.clear()

    # --- the mission's record ----------------------------------------------------------------
    def log(self, text: str) -> None:
        self.events.append((self.now, text))
        for listener in list(self.listeners):
            listener(self.now, text)

    def feedback(self, text: str, **progress: float) -> None:
        """What the mission is doing now; ``progress`` numbers go to the mission state."""
        self.status_text = text
        self.progress.update({k: float(v) for k, v in progress.items()})

    def fail(self, behaviour: str, reason: str) -> FailureRecord:
        record = FailureRecord(behaviour, reason, self.now)
        self.failures.append(record)
        self.log(f"FAILED {record.describe()}")
        return record

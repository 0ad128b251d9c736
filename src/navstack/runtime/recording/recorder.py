"""``BagRecorder``: record bus topics into a rosbag2 folder (MCAP storage, CDR).

Like ``ros2 bag record``: each recorded topic becomes a connection with its ROS 2 type,
message definition and offered QoS (latched bus topics -- ``/map``, ``/tf_static``,
``/plan``, ``/amcl_pose`` -- as ``transient_local``, the rest ``volatile``), and every
message is stored with its publish time on the scheduler clock as the bag (log) time.
Messages a latched topic already holds when recording starts are written at the start
time, as a transient-local subscription would receive them.

*Cost.*  The recorder observes the bus through a tap (no subscription, so no scheduler
event per message); the high-rate types are packed straight into CDR (:mod:`.cdr`), the
rest go through rosbags; the MCAP writer buffers messages into 1 MiB chunks before they
reach the file.  ``navstack bench recording`` measures the overhead on the demo.

*Goals.*  In-process actions have no bus topic, so with ``record_goals`` the recorder
observes the ``/navigate_to_pose`` action server and writes what a rosbag2 recording of
Nav2 holds: ``/goal_pose`` (the goal; skipped when something on the bus publishes
``/goal_pose`` itself) and ``/navigate_to_pose/_action/status`` (``EXECUTING`` when the
goal is accepted, then ``SUCCEEDED`` / ``CANCELED`` / ``ABORTED`` when it ends).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from navstack.core.msgs import PoseStamped
from navstack.runtime.bus import Bus
from navstack.runtime.node import Runtime
from navstack.runtime.recording.convert import RosCodec
from navstack.runtime.recording.errors import BagError, UnsupportedTypeError
from navstack.runtime.recording.goal_status import (
    STATUS_CODES,
    STATUS_EXECUTING,
    GoalInfo,
    GoalStatusArray,
    GoalStatusEntry,
    goal_uuid,
)
from navstack.runtime.recording.writer import BagSummary, BagWriter, Route

#: ``ros2 bag record`` of a navigation run: sensors, TF, localization, plans, commands,
#: goals, the map, and the simulator's ground truth when there is one (true pose, the
#: body's footprint and the walkers, so ``navstack report`` can score clearance).
DEFAULT_TOPICS: tuple[str, ...] = (
    "/scan", "/tf", "/tf_static", "/odom", "/plan", "/local_plan", "/cmd_vel", "/amcl_pose",
    "/map", "/goal_pose", "/ground_truth", "/sim/footprint", "/sim/obstacles")
NAVIGATE_TO_POSE = "/navigate_to_pose"
GOAL_POSE_TOPIC = "/goal_pose"
GOAL_STATUS_TOPIC = NAVIGATE_TO_POSE + "/_action/status"


class BagRecorder:
    """Records chosen topics of a running bus into a rosbag2 folder until :meth:`close`.

    ``topics``: names to record (default :data:`DEFAULT_TOPICS`); ``all_topics=True``
    records every topic whose type has a ROS 2 counterpart (the others are listed in
    ``summary.skipped``).  A chosen topic whose type has none raises
    :class:`UnsupportedTypeError` naming it when it first appears.  ``replace`` lets the
    recorder overwrite an existing bag folder (metadata.yaml plus storage files only).
    """

    def __init__(self, runtime: Runtime | Bus, path: str | Path,
                 topics: Iterable[str] = DEFAULT_TOPICS, *, all_topics: bool = False,
                 storage: str = "mcap", record_goals: bool = True, replace: bool = False,
                 codec: RosCodec | None = None) -> None:
        self.bus = runtime.bus if isinstance(runtime, Runtime) else runtime
        self.path = Path(path)
        self.wanted: set[str] | None = None if all_topics else {_abs(t) for t in topics}
        self.writer = BagWriter(self.path, storage=storage, replace=replace, codec=codec)
        self._route: dict[str, Route | None] = {}
        now = self.bus.scheduler.now
        for name, topic in list(self.bus.topics.items()):
            if topic.latched and self._connection(name, topic.msg_type) is not None:
                for msg in topic.latched:
                    self._tap(name, msg, now)
        self._remove_tap = self.bus.add_tap(self._tap)
        self._goal_hook: tuple[Any, Any] | None = None
        if record_goals:
            self._hook_goals()

    @property
    def summary(self) -> BagSummary:
        return self.writer.summary

    @property
    def closed(self) -> bool:
        return self.writer.closed

    # --- bus -------------------------------------------------------------------------------
    def _connection(self, topic: str, msg_type: type) -> Route | None:
        """The route of ``topic`` (connection + encoder), ``None`` if it is not recorded."""
        if topic in self._route:
            return self._route[topic]
        route = None
        if self.wanted is None or topic in self.wanted:
            bus_topic = self.bus.topics.get(topic)
            held = bus_topic.latched if bus_topic is not None else None
            try:
                route = self.writer.route(topic, msg_type, held is not None,
                                          (held.maxlen or 1) if held is not None else 10)
            except UnsupportedTypeError as exc:
                if self.wanted is not None:
                    raise
                self.summary.skipped[topic] = str(exc)
        self._route[topic] = route
        return route

    def _tap(self, topic: str, msg: Any, now: float) -> None:
        route = self._route[topic] if topic in self._route else self._connection(topic,
                                                                                 type(msg))
        if route is not None:
            self.writer.write_routed(topic, route, msg, now)

    def write(self, topic: str, msg: Any, t: float | None = None) -> None:
        """Write ``msg`` on ``topic`` at time ``t`` (default now) without the bus -- events
        that have no bus topic.  The topic is recorded from then on even if not chosen."""
        if self.closed:
            raise BagError(f"{self.path}: the recording is closed; cannot write {topic}")
        topic = _abs(topic)
        if self._route.get(topic) is None:
            self._route.pop(topic, None)
            if self.wanted is not None:
                self.wanted.add(topic)
            self.summary.skipped.pop(topic, None)
            self.writer.codec.ros_type(type(msg), topic)  # unsupported: raises, naming it
        route = self._connection(topic, type(msg))
        if route is None:
            raise BagError(f"{self.path}: cannot record topic '{topic}'")
        self.writer.write_routed(topic, route, msg, self.bus.scheduler.now if t is None else t)

    # --- goals -----------------------------------------------------------------------------
    def _hook_goals(self) -> None:
        server = self.bus.action_servers.get(NAVIGATE_TO_POSE)
        if server is None:
            return
        original = server.on_goal

        def on_goal(handle: Any) -> Any:
            verdict = original(handle)
            if verdict is True and not self.closed:
                self._goal_accepted(handle)
            return verdict

        server.on_goal = on_goal
        self._goal_hook = (server, original)

    def _goal_accepted(self, handle: Any) -> None:
        now = self.bus.scheduler.now
        info = GoalInfo(goal_uuid(handle.goal_id), now)
        pose = getattr(handle.goal, "pose", None)
        on_bus = self.bus.topics.get(GOAL_POSE_TOPIC)
        if isinstance(pose, PoseStamped) and (on_bus is None or on_bus.count == 0):
            self.write(GOAL_POSE_TOPIC, pose, now)
        self.write(GOAL_STATUS_TOPIC, GoalStatusArray((GoalStatusEntry(info, STATUS_EXECUTING),)))

        def done(result: Any) -> None:
            code = STATUS_CODES.get(result.status)
            if code is not None and not self.closed:
                self.write(GOAL_STATUS_TOPIC, GoalStatusArray((GoalStatusEntry(info, code),)))

        handle.add_done_callback(done)

    # --- closing ---------------------------------------------------------------------------
    def close(self) -> BagSummary:
        """Stop recording and write the bag's index and metadata.yaml; returns the summary."""
        if not self.closed:
            self._remove_tap()
            if self._goal_hook is not None:
                server, original = self._goal_hook
                server.on_goal = original
                self._goal_hook = None
        return self.writer.close()

    def __enter__(self) -> BagRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _abs(topic: str) -> str:
    return topic if topic.startswith("/") else "/" + topic

"""``HealthMonitor``: live health of a running :class:`NavStack`, evaluated on demand.

The monitor watches the bus through a tap (it adds no subscription, so no scheduler event
per message and no change to the run) and keeps ``history`` seconds of what the checks
need: publish times per topic, ``/cmd_vel`` and ``/odom`` samples, the stamps of every
``/tf`` edge, plans and localization covariances.  It also observes the navigator's and
the controller's action servers, as a rosbag2 recording of Nav2 does, for goal spans and
FollowPath aborts.  :meth:`HealthMonitor.report` runs every check of
:mod:`.checks` against that and the stack's live state (lifecycle, costmaps,
controller limits).

Threading: like every object of the stack, call it from the simulation thread (a
:class:`~navstack.interfaces.live_runner.LiveRunner` client uses ``runner.submit``).
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from navstack.core.errors import TransformError
from navstack.core.msgs import (
    Odometry,
    Path,
    PoseWithCovarianceStamped,
    TFMessage,
    Twist,
)
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.costmap.footprint import footprint_cost
from navstack.interfaces.health.analysis import blocked_fraction, pose_stds
from navstack.interfaces.health.checks import all_checks
from navstack.interfaces.health.model import (
    CheckResult,
    CostmapSnapshot,
    GoalSpan,
    HealthParams,
    Observations,
)
from navstack.interfaces.stack import NavStack
from navstack.navigation.costmap_node import CostmapNode
from navstack.navigation.messages import FOLLOW_PATH, NAVIGATE_THROUGH_POSES, NAVIGATE_TO_POSE
from navstack.runtime.actions import ActionResult, GoalHandle, GoalStatus

LOCALIZATION_TOPICS: dict[str, type[PoseWithCovarianceStamped] | type[Odometry]] = {
    "/amcl_pose": PoseWithCovarianceStamped, "/odometry/filtered": Odometry}
"""Localization estimates whose covariance the health checks bound (AMCL, EKF)."""
_LIMIT_KEYS = ("max_vel_x", "max_speed_xy", "max_vel_theta", "desired_linear_vel", "vx_max",
               "wz_max")


class HealthMonitor:
    """Watches ``stack`` from construction on (starting it if it was not yet);
    :meth:`report` evaluates the checks."""

    def __init__(self, stack: NavStack, params: HealthParams | None = None,
                 history: float = 30.0) -> None:
        self.stack = stack.start()
        self.params = params or HealthParams()
        self.history = max(history, self.params.window,
                           self.params.movement_time_allowance + self.params.window)
        self.runtime = stack.runtime
        self.start = self.runtime.now
        self._times: dict[str, deque[float]] = {}
        self._cmd: deque[tuple[float, float, float]] = deque()
        self._odom: deque[tuple[float, float, float, float, float, float]] = deque()
        self._tf: dict[str, deque[tuple[float, float]]] = {}
        self._plans: deque[tuple[float, str]] = deque(maxlen=100)
        self._cov: deque[tuple[float, float, float, float]] = deque(maxlen=100)
        self._cov_topic = ""
        self.goals: list[dict[str, Any]] = []
        self.follow_path_failures: list[tuple[float, int, str]] = []
        self._hooks: list[tuple[Any, Any, Any]] = []
        self._closed = False
        self._remove_tap = self.runtime.bus.add_tap(self._tap)
        for action in (NAVIGATE_TO_POSE, NAVIGATE_THROUGH_POSES):
            self._hook(action, self._navigation_goal)
        self._hook(FOLLOW_PATH, self._follow_path_goal)

    # --- observation -------------------------------------------------------------------
    def _tap(self, topic: str, msg: Any, now: float) -> None:
        horizon = now - self.history
        times = self._times.get(topic)
        if times is None:
            times = self._times[topic] = deque()
        times.append(now)
        while times[0] < horizon:
            times.popleft()
        if topic == "/cmd_vel" and isinstance(msg, Twist):
            self._cmd.append((now, msg.linear.x, msg.angular.z))
            while self._cmd[0][0] < horizon:
                self._cmd.popleft()
        elif topic == "/odom" and isinstance(msg, Odometry):
            p, tw = msg.pose.pose, msg.twist.twist
            self._odom.append((msg.header.stamp, p.position.x, p.position.y,
                               p.orientation.yaw, tw.linear.x, tw.angular.z))
            while self._odom[0][0] < horizon:
                self._odom.popleft()
        elif topic == "/tf" and isinstance(msg, TFMessage):
            for ts in msg.transforms:
                key = f"{ts.header.frame_id}->{ts.child_frame_id}"
                edge = self._tf.get(key)
                if edge is None:
                    edge = self._tf[key] = deque()
                edge.append((now, ts.header.stamp))
                while len(edge) > 1 and edge[1][0] < horizon:
                    edge.popleft()  # keep the newest sample before the horizon
        elif topic == "/plan" and isinstance(msg, Path):
            self._plans.append((now, msg.header.frame_id))
        elif topic in LOCALIZATION_TOPICS and isinstance(msg, LOCALIZATION_TOPICS[topic]):
            self._cov_topic = topic
            self._cov.append((now, *pose_stds(msg.pose.covariance)))

    def _hook(self, action: str, on_accept: Any) -> None:
        server = self.runtime.bus.action_servers.get(action)
        if server is None:
            return
        original = server.on_goal

        def on_goal(handle: GoalHandle[Any]) -> Any:
            verdict = original(handle)
            if not self._closed:
                on_accept(handle, verdict)
            return verdict

        server.on_goal = on_goal
        self._hooks.append((server, original, on_goal))

    def _navigation_goal(self, handle: GoalHandle[Any], verdict: Any) -> None:
        now = self.runtime.now
        record: dict[str, Any] = {"start": now, "end": None, "status": "EXECUTING",
                                  "code": 0, "reason": ""}
        if verdict is not True:
            record.update(end=now, status="REJECTED",
                          reason=verdict if isinstance(verdict, str) else "rejected")
        self.goals.append(record)

        def done(result: ActionResult) -> None:
            record.update(end=self.runtime.now, status=result.status.value,
                          code=result.error_code, reason=result.error_msg)

        if verdict is True:
            handle.add_done_callback(done)

    def _follow_path_goal(self, handle: GoalHandle[Any], verdict: Any) -> None:
        def done(result: ActionResult) -> None:
            if result.status is GoalStatus.FAILED and not self._closed:
                self.follow_path_failures.append((self.runtime.now, result.error_code,
                                                  result.error_msg))

        if verdict is True:
            handle.add_done_callback(done)

    def close(self) -> None:
        """Stop observing (the recorded history stays readable)."""
        if self._closed:
            return
        self._closed = True
        self._remove_tap()
        for server, original, mine in self._hooks:
            if server.on_goal is mine:  # leave hooks installed after ours in place
                server.on_goal = original
        self._hooks.clear()

    # --- the stack's own state ---------------------------------------------------------
    def _expected_rates(self) -> dict[str, float]:
        sensors = self.stack.robot.sensors
        rates: dict[str, float] = {}
        if sensors.lidar.enabled:
            rates["/scan"] = sensors.lidar.rate_hz
        if sensors.odometry.enabled:
            rates["/odom"] = rates["/tf"] = sensors.odometry.rate_hz
        rates["/cmd_vel"] = self.stack.controller.params.controller_frequency
        return rates

    def _velocity_limits(self) -> dict[str, float]:
        limits: dict[str, float] = {}
        for cname, ctrl in self.stack.controller.controllers.items():
            # a wrapper (the rotation shim) shares its section with its primary controller
            for c in (ctrl, getattr(ctrl, "primary", None)):
                p = getattr(c, "params", None)
                for key in _LIMIT_KEYS:
                    if p is not None and hasattr(p, key):
                        limits[f"{cname}.{key}"] = float(getattr(p, key))
        k = self.stack.robot.kinematics
        limits["robot.max_vel_x"] = float(k.max_vel_x)
        limits["robot.max_vel_theta"] = float(k.max_vel_theta)
        return limits

    def _progress_rule(self) -> tuple[float, float] | None:
        from navstack.control.progress_checker import SimpleProgressChecker

        for checker in self.stack.controller.progress_checkers.values():
            if isinstance(checker, SimpleProgressChecker):
                p = checker.params
                return float(p.required_movement_radius), float(p.movement_time_allowance)
        return None

    def _costmap(self, node: CostmapNode) -> CostmapSnapshot:
        cm = node.costmap
        known, frac = blocked_fraction(cm.data)
        cost: int | None = None
        try:
            pose = self.runtime.tf.lookup_pose2d(node.global_frame, node.robot_base_frame)
        except TransformError:
            pose = None
        if pose is not None:
            cost = footprint_cost(cm, (pose.x, pose.y, pose.theta), self.stack.body_footprint)
        return CostmapSnapshot(node.name, cm.frame_id, known, frac, cost,
                               cost == LETHAL_OBSTACLE)

    def _sensor_frames(self, base: str) -> tuple[str, ...]:
        tf = self.runtime.tf
        if base not in tf:
            return ()
        return tuple(f for f in tf.frames() if f != base and tf.parent_of(f) == base)

    # --- results -----------------------------------------------------------------------
    def observations(self, span: float | None = None) -> Observations:
        """Everything observed, judged over the last ``span`` seconds (default: the
        progress allowance plus the rate window; ``inf``: since the monitor started)."""
        now = self.runtime.now
        if span is None:
            span = self.params.movement_time_allowance + self.params.window
        stack = self.stack
        bus = self.runtime.bus
        base = stack.local_costmap.robot_base_frame
        latched = {}
        if stack.map_server is not None or stack.slam is not None:
            topic = bus.topics.get("/map")
            latched["/map"] = bool(topic is not None and topic.latched)
        cmd_topic = bus.topics.get("/cmd_vel")
        return Observations(
            source="live", start=max(self.start, now - span), now=now,
            topic_times={k: np.fromiter(v, dtype=np.float64, count=len(v))
                         for k, v in self._times.items()},
            expected_rates=self._expected_rates(), latched=latched,
            cmd=np.array(self._cmd, dtype=np.float64).reshape(-1, 3),
            odom=np.array(self._odom, dtype=np.float64).reshape(-1, 6),
            tf=self.runtime.tf,
            tf_samples={k: np.array(v, dtype=np.float64).reshape(-1, 2)
                        for k, v in self._tf.items()},
            global_frame=stack.global_costmap.global_frame,
            odom_frame=stack.local_costmap.global_frame, base_frame=base,
            sensor_frames=self._sensor_frames(base),
            goals=[GoalSpan(g["start"], g["end"], g["status"], g["code"], g["reason"])
                   for g in self.goals],
            plans=list(self._plans),
            costmaps=[self._costmap(stack.global_costmap), self._costmap(stack.local_costmap)],
            covariance=np.array(self._cov, dtype=np.float64).reshape(-1, 4),
            covariance_topic=self._cov_topic,
            follow_path_failures=list(self.follow_path_failures),
            node_states={n: node.state.value for n, node in self.runtime.nodes.items()},
            controller_node=stack.controller.name,
            velocity_limits=self._velocity_limits(), progress_rule=self._progress_rule(),
            base_subscribers=len(cmd_topic.subscriptions) if cmd_topic is not None else 0)

    def report(self, span: float | None = None) -> list[CheckResult]:
        """Every health check on the last ``span`` seconds (see :meth:`observations`)."""
        return all_checks(self.observations(span), self.params)

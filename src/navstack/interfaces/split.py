"""Robot / base-station split of the default stack over Zenoh (issue 21).

``navstack robot`` runs what must keep working when the radio drops: the simulator (or
drivers) with odometry, the local costmap, the controller and behavior servers, the
command chain (velocity smoother, collision monitor, twist_mux) and the
:class:`~navstack.nodes.link_watchdog.LinkWatchdog` in front of the base.
``navstack base`` runs the map server, global costmap, planner, BT navigator and
waypoint follower, and sends the mission.  Between them (:func:`robot_wiring`):

==================  ============  =====================================================
what                direction     how
==================  ============  =====================================================
/scan /odom /tf     robot->base   topics, CDR (stamps compensated on receipt)
/tf_static          robot->base   latched topic (late joiner reads the store)
/map                base->robot   latched topic (the robot's local static layer)
follow_path, spin,  base->robot   actions (goal query, feedback/result puts, acks)
backup, ...
clear local costmap base->robot   services
==================  ============  =====================================================

Both processes run on a wall clock (``transport.<name>.clock.rate`` may accelerate it
for tests; both must use the same rate) with the process's ``clock.offset``.
"""

from __future__ import annotations

import json
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from navstack.core.errors import ConfigError
from navstack.core.msgs import (
    Header,
    LaserScan,
    OccupancyGrid,
    Odometry,
    PoseStamped,
    TFMessage,
    Twist,
)
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.costmap.footprint import footprint_cost
from navstack.interfaces.health.checks import clock_contract
from navstack.interfaces.stack import NavStack
from navstack.navigation import messages as m
from navstack.navigation.behavior_server import BehaviorServer
from navstack.navigation.bt_navigator import BtNavigator
from navstack.navigation.collision_monitor_node import CollisionMonitorNode
from navstack.navigation.controller_server import ControllerServer
from navstack.navigation.costmap_node import CostmapNode
from navstack.navigation.map_server import MapServer
from navstack.navigation.planner_server import PlannerServer
from navstack.navigation.velocity_smoother_node import VelocitySmootherNode
from navstack.navigation.waypoint_follower import load_waypoints
from navstack.nodes.link_watchdog import LinkWatchdog
from navstack.nodes.twist_mux import TwistMuxNode
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS
from navstack.runtime.config import load_stack
from navstack.runtime.node import Runtime
from navstack.runtime.scheduler import Scheduler
from navstack.runtime.transports.config import TransportSection
from navstack.runtime.transports.keys import namespaced
from navstack.runtime.transports.lockstep import Lockstep
from navstack.runtime.transports.remote_calls import (
    ActionProxy,
    proxy_service,
    serve_action,
    serve_service,
)
from navstack.runtime.transports.zenoh_link import ZenohLink
from navstack.sim.node import SimulatorNode
from navstack.sim.simulator import Simulator

#: robot -> base topics: (name, type, QoS)
ROBOT_TOPICS: tuple[tuple[str, type, QoS], ...] = (
    ("/scan", LaserScan, SENSOR_DATA), ("/odom", Odometry, QoS(depth=10)),
    ("/tf", TFMessage, QoS(depth=100)), ("/tf_static", TFMessage, QoS(depth=100, latched=True)))
#: base -> robot topics
BASE_TOPICS: tuple[tuple[str, type, QoS], ...] = (("/map", OccupancyGrid, LATCHED),)
ROBOT_SERVICES = (m.CLEAR_LOCAL_COSTMAP, m.CLEAR_AROUND_LOCAL_COSTMAP)


def robot_actions(stack: NavStack) -> tuple[str, ...]:
    """The actions the robot serves: follow_path and the configured behaviors."""
    return (m.FOLLOW_PATH, *(f"/{k}" for k in stack.description.behavior_server.behaviors))


def transport_for(stack_file: str | FsPath, name: str,
                  overrides: dict[str, Any] | None = None) -> TransportSection:
    """The stack file's ``transport.<name>`` section with command-line ``overrides``."""
    cfg = load_stack(stack_file)
    section = cfg.transport.get(name)
    if section is None:
        raise ConfigError(f"no transport section for process '{name}'",
                          file=str(stack_file), key_path=f"transport.{name}",
                          suggestion="add e.g. 'transport: {" + name + ": {kind: zenoh, "
                          "listen: [\"tcp/127.0.0.1:7447\"], peers: [base]}}'")
    data = section.model_dump()
    for key, value in (overrides or {}).items():
        if key.startswith("clock."):
            data["clock"][key.split(".", 1)[1]] = value
        elif key.startswith("impairments."):
            data["impairments"][key.split(".", 1)[1]] = value
        else:
            data[key] = value
    out = TransportSection.from_mapping(data, file=str(stack_file),
                                        key_path=f"transport.{name}")
    if out.kind != "zenoh":
        raise ConfigError(f"is '{out.kind}'; the split needs 'zenoh'", file=str(stack_file),
                          key_path=f"transport.{name}.kind")
    if not out.peers:
        raise ConfigError("names no peers", file=str(stack_file),
                          key_path=f"transport.{name}.peers",
                          suggestion="list the process(es) this one talks to, e.g. [base]")
    return out.updated(name=name)


def wall_runtime(t: TransportSection) -> Runtime:
    """The process's runtime: a wall clock, or (``clock.mode: lockstep``) stepped time
    starting at the shared epoch plus this process's offset."""
    if t.clock.mode == "lockstep":
        return Runtime(Scheduler("sim", start_time=Scheduler.EPOCH + t.clock.offset))
    return Runtime(Scheduler("wall", rate=t.clock.rate, clock_offset=t.clock.offset))


@dataclass
class RobotProcess:
    """The robot half, built and running (see module docstring)."""

    stack: NavStack
    transport: TransportSection
    runtime: Runtime = field(init=False)
    link: ZenohLink = field(init=False)

    def __post_init__(self) -> None:
        d, t = self.stack.description, self.transport
        base = t.peers[0]
        rt = self.runtime = wall_runtime(t)
        rt.scheduler.lateness = deque(maxlen=200_000)
        self.link = link = ZenohLink(rt, t, peers=t.peers)
        self.lockstep = (Lockstep(link, "master", base, t.clock.quantum)
                         if t.clock.mode == "lockstep" else None)
        simulator = Simulator(d.world, d.robot, d.seed, d.spawn)
        simulator.time = rt.now  # the world starts now on the wall clock, not at 0
        self.sim = SimulatorNode(rt, simulator, d.physics_rate_hz, True)
        self.local_costmap = CostmapNode(rt, "local_costmap", d.local_costmap, d.footprint,
                                         d.nav2_file)
        self.controller = ControllerServer(rt, d.controller_server, self.local_costmap,
                                           d.footprint, d.nav2_file)
        self.behaviors = BehaviorServer(rt, d.behavior_server,
                                        collision_checker=self._collides)
        # the command chain as in process, the mux feeding the link watchdog, not the base
        self.smoother = VelocitySmootherNode(rt, d.velocity_smoother)
        self.monitor = CollisionMonitorNode(rt, d.body_footprint, d.collision_monitor)
        self.mux = TwistMuxNode(rt, d.twist_mux.model_copy(
            update={"cmd_vel_out": "/cmd_vel_guarded"}))
        self.watchdog = LinkWatchdog(rt, lambda: link.peer_up(base))
        for name, typ, qos in ROBOT_TOPICS:
            link.export_topic(name, typ, qos=qos)
        for name, typ, qos in BASE_TOPICS:
            link.import_topic(namespaced("", name), typ, peer=base, qos=qos)
        self.cmd_log: list[tuple[float, float, float]] = []
        rt.bus.subscribe("/cmd_vel", Twist, lambda c: self.cmd_log.append(
            (rt.now, c.linear.x, c.angular.z)), QoS(depth=100))
        rt.bring_up()
        for action in robot_actions(self.stack):
            serve_action(link, action, base)
        for service in ROBOT_SERVICES:
            serve_service(link, service, base)
        self.rows: list[tuple[float, float, float, float]] = []
        rt.scheduler.create_timer(0.1, self._sample, first_at=rt.now)

    def _collides(self, pose_odom: Any) -> bool:
        cost = footprint_cost(self.local_costmap.costmap,
                              (pose_odom.x, pose_odom.y, pose_odom.theta),
                              self.stack.description.body_footprint)
        return bool(cost == LETHAL_OBSTACLE)

    def _sample(self) -> None:
        self.sim.advance()
        p = self.sim.sim.pose
        self.rows.append((self.runtime.now, p.x, p.y, p.theta))

    def run(self, max_s: float, idle_exit_s: float = 5.0) -> dict[str, Any]:
        """Run until the base has come and gone (its liveliness token vanished for
        ``idle_exit_s``) or ``max_s`` process seconds passed; returns the report."""
        base = self.transport.peers[0]
        sched = self.runtime.scheduler
        seen = [False]
        gone_since = [math.inf]

        def finished() -> bool:
            present = base in self.link.present
            seen[0] = seen[0] or present
            if present or not seen[0]:
                gone_since[0] = math.inf
            elif gone_since[0] == math.inf:
                gone_since[0] = time.monotonic()
            return time.monotonic() - gone_since[0] > idle_exit_s / self.transport.clock.rate

        t0 = sched.now
        while sched.now - t0 < max_s and not finished():
            sched.run_for(0.5, until=finished)
        return self.report()

    def report(self) -> dict[str, Any]:
        base = self.transport.peers[0]
        return {"role": "robot", "name": self.transport.name,
                "collisions": self.sim.sim.collisions,
                "trajectory": self.rows, "cmd_vel": self.cmd_log,
                "watchdog": {"stops": self.watchdog.stops, "resumes": self.watchdog.resumes,
                             "blocked": self.watchdog.blocked},
                "opened_at": self.link.opened_at,
                "clock_offset_configured_s": self.transport.clock.offset,
                "link": self.link.health(), "latency_s": _latency(self.link),
                "base_offset_s": self.link.offset(base),
                "loop_lateness_s": _percentiles(list(self.runtime.scheduler.lateness or ()))}

    def close(self) -> None:
        self.link.close()


@dataclass
class BaseProcess:
    """The base-station half, built and running (see module docstring)."""

    stack: NavStack
    transport: TransportSection
    runtime: Runtime = field(init=False)
    link: ZenohLink = field(init=False)

    def __post_init__(self) -> None:
        d, t = self.stack.description, self.transport
        robot = t.peers[0]
        rt = self.runtime = wall_runtime(t)
        self.link = link = ZenohLink(rt, t, peers=t.peers)
        self.lockstep = (Lockstep(link, "follower", robot, t.clock.quantum)
                         if t.clock.mode == "lockstep" else None)
        self.map_server = MapServer(rt, grid=d.map_grid or d.world.to_occupancy_grid())
        self.global_costmap = CostmapNode(rt, "global_costmap", d.global_costmap, d.footprint,
                                          d.nav2_file)
        self.planner = PlannerServer(rt, d.planner_server, self.global_costmap, d.nav2_file,
                                     footprint=d.footprint)
        for name, typ, qos in ROBOT_TOPICS:
            link.import_topic(name, typ, peer=robot, qos=qos)
        for name, typ, qos in BASE_TOPICS:
            link.export_topic(name, typ, qos=qos)
        self.proxies = [ActionProxy(link, action, action, robot)
                        for action in robot_actions(self.stack)]
        for service in ROBOT_SERVICES:
            proxy_service(link, service, service, robot)
        self.navigator = BtNavigator(rt, d.bt_navigator, tree_params=d.navigate_tree)
        rt.bring_up()

    def wait_for_robot(self, timeout_s: float = 30.0) -> None:
        """Run until the robot's clock is estimated and ``map -> base_link`` is known."""
        robot = self.transport.peers[0]
        rt = self.runtime
        ok = rt.scheduler.run_for(timeout_s * self.transport.clock.rate, until=lambda: (
            self.link.ready(robot) and rt.tf.can_transform("map", "base_link")))
        if not ok:
            raise ConfigError(f"robot '{robot}' not reachable within {timeout_s:g} s: no "
                              f"clock answer or no map -> base_link (is `navstack robot` "
                              f"running and transport.connect pointing at it?)")
        self.global_costmap.update()

    def run_mission(self, waypoints: list[tuple[str, PoseStamped]],
                    goal_timeout_s: float = 240.0) -> dict[str, Any]:
        """Send each waypoint as a NavigateToPose goal in turn; returns the report."""
        rt = self.runtime
        client: ActionClient[m.NavigateToPoseGoal] = ActionClient(rt.bus, m.NAVIGATE_TO_POSE)
        goals = []
        for name, pose in waypoints:
            t0 = rt.now
            pose = PoseStamped(Header(rt.now, pose.header.frame_id), pose.pose)
            handle = client.send_goal(m.NavigateToPoseGoal(pose))
            done = _done_of(handle)
            rt.scheduler.run_for(goal_timeout_s, until=done)
            if not handle.done:
                handle.cancel()
                rt.scheduler.run_for(2.0, until=done)
            result = handle.result
            status = handle.status.value if handle.done else "TIMEOUT"
            goals.append({"name": name, "status": status, "time_s": round(rt.now - t0, 3),
                          "reason": result.error_msg if result is not None else ""})
            print(f"[base] {name}: {status} in {rt.now - t0:.1f} s"
                  + (f" ({result.error_msg})" if result is not None and result.error_msg
                     else ""), flush=True)
        return self.report(goals)

    def report(self, goals: list[dict[str, Any]]) -> dict[str, Any]:
        robot = self.transport.peers[0]
        goal_rtt = sorted(x for p in self.proxies for x in p.goal_latency)
        contract = clock_contract(robot, self.link.health()[robot],
                                  self.transport.clock.tolerance)
        return {"role": "base", "name": self.transport.name, "goals": goals,
                "succeeded": sum(g["status"] == GoalStatus.SUCCEEDED.value for g in goals),
                "link": self.link.health(), "latency_s": _latency(self.link),
                "goal_round_trip_s": _percentiles(goal_rtt),
                "actions": {p.remote: p.outcomes for p in self.proxies},
                "robot_offset_s": self.link.offset(robot),
                "clock_contract": {"name": contract.name, "ok": contract.ok,
                                   "detail": contract.detail, "fix": contract.fix}}

    def close(self) -> None:
        self.link.close()


def _done_of(handle: GoalHandle[Any]) -> Callable[[], bool]:
    return lambda: handle.done


def _percentiles(values: list[float]) -> dict[str, float]:
    if not values:
        return {}
    arr = np.asarray(values)
    return {"n": int(arr.size), "p50": float(np.percentile(arr, 50)),
            "p99": float(np.percentile(arr, 99)), "max": float(arr.max())}


def _latency(link: ZenohLink) -> dict[str, dict[str, float]]:
    return {topic: _percentiles(list(s.latencies)) for topic, s in link.topic_stats.items()}


def run_robot(stack_file: str | FsPath, name: str = "robot", max_s: float = 1200.0,
              overrides: dict[str, Any] | None = None, out: FsPath | None = None,
              stop_when_base_leaves: bool = True) -> dict[str, Any]:
    t = transport_for(stack_file, name, overrides)
    proc = RobotProcess(NavStack.from_stack_file(stack_file), t)
    try:
        report = proc.run(max_s, 5.0 if stop_when_base_leaves else math.inf)
    finally:
        proc.close()
    if out is not None:
        out.write_text(json.dumps(report) + "\n")
    return report


def run_base(stack_file: str | FsPath, waypoints_file: str | FsPath, name: str = "base",
             overrides: dict[str, Any] | None = None, out: FsPath | None = None,
             goal_timeout_s: float = 240.0) -> dict[str, Any]:
    t = transport_for(stack_file, name, overrides)
    waypoints = load_waypoints(waypoints_file)
    proc = BaseProcess(NavStack.from_stack_file(stack_file), t)
    try:
        proc.wait_for_robot()
        report = proc.run_mission(waypoints, goal_timeout_s)
    finally:
        proc.close()
    if out is not None:
        out.write_text(json.dumps(report) + "\n")
    return report

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
for tests; both must use the same rate) with the process's ``clock.offset``, or in
lockstep simulated time (:mod:`navstack.runtime.transports.lockstep`).  The nodes of each
half are built by :mod:`navstack.interfaces.split_nodes`, which also runs both halves in
one process as the reference of a split run.
"""

from __future__ import annotations

import json
import math
import time
from collections import deque
from pathlib import Path as FsPath
from typing import Any, Literal

import numpy as np

from navstack.core.errors import ConfigError
from navstack.core.msgs import LaserScan, OccupancyGrid, Odometry, PoseStamped, TFMessage
from navstack.interfaces.health.checks import clock_contract
from navstack.interfaces.split_nodes import (
    MISSION_START_S,
    BaseNodes,
    RobotNodes,
    drive_mission,
    succeeded,
)
from navstack.interfaces.stack import NavStack
from navstack.navigation import messages as m
from navstack.navigation.waypoint_follower import load_waypoints
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS
from navstack.runtime.config import load_stack
from navstack.runtime.node import Runtime
from navstack.runtime.scheduler import Scheduler
from navstack.runtime.transports.config import TransportSection
from navstack.runtime.transports.keys import namespaced
from navstack.runtime.transports.lockstep import SIM_EPOCH, Lockstep
from navstack.runtime.transports.remote_calls import (
    ActionProxy,
    proxy_service,
    serve_action,
    serve_service,
)
from navstack.runtime.transports.zenoh_link import ZenohLink

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
    starting at :data:`~navstack.runtime.transports.lockstep.SIM_EPOCH` plus this
    process's offset."""
    if t.clock.mode == "lockstep":
        return Runtime(Scheduler("sim", start_time=SIM_EPOCH + t.clock.offset))
    return Runtime(Scheduler("wall", rate=t.clock.rate, clock_offset=t.clock.offset))


class _Process:
    """What both halves set up alike: the runtime on the process clock, the Zenoh link
    to the one peer and, in lockstep, the time coupling (``role`` of this side)."""

    def __init__(self, stack: NavStack, transport: TransportSection,
                 role: Literal["master", "follower"]) -> None:
        self.stack, self.transport = stack, transport
        self.peer = transport.peers[0]
        self.runtime = rt = wall_runtime(transport)
        self.link = ZenohLink(rt, transport, peers=transport.peers)
        self.lockstep = (Lockstep(self.link, role, self.peer, transport.clock.quantum)
                         if transport.clock.mode == "lockstep" else None)

    def common_report(self) -> dict[str, Any]:
        return {"name": self.transport.name, "link": self.link.health(),
                "latency_s": _latency(self.link), "lockstep": self.lockstep is not None,
                "late_deliveries": self.runtime.scheduler.late_posts,
                "link_send": self.link.send_stats(),
                "clock_rate": self.transport.clock.rate}

    def close(self) -> None:
        self.link.close()


class RobotProcess(_Process):
    """The robot half, built and running (see module docstring)."""

    def __init__(self, stack: NavStack, transport: TransportSection) -> None:
        super().__init__(stack, transport, "master")
        rt, link, base = self.runtime, self.link, self.peer
        rt.scheduler.lateness = deque(maxlen=200_000)
        self.nodes = RobotNodes(rt, stack, lambda: link.peer_up(base))
        for name, typ, qos in ROBOT_TOPICS:
            link.export_topic(name, typ, qos=qos)
        for name, typ, qos in BASE_TOPICS:
            link.import_topic(namespaced("", name), typ, peer=base, qos=qos)
        rt.bring_up()
        for action in robot_actions(stack):
            serve_action(link, action, base)
        for service in ROBOT_SERVICES:
            serve_service(link, service, base)
        self.nodes.start_sampling()

    def run(self, max_s: float, idle_exit_s: float = 5.0) -> dict[str, Any]:
        """Run until the base has come and gone (its liveliness token vanished for
        ``idle_exit_s``) or ``max_s`` process seconds passed; returns the report."""
        sched = self.runtime.scheduler
        seen = [False]
        gone_since = [math.inf]

        def finished() -> bool:
            present = self.peer in self.link.present
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
        n = self.nodes
        return {"role": "robot", **self.common_report(),
                "collisions": n.collisions,
                "trajectory": n.rows, "cmd_vel": n.cmd_log,
                **n.latency.report(),
                "watchdog": {"stops": n.watchdog.stops, "resumes": n.watchdog.resumes,
                             "blocked": n.watchdog.blocked},
                "opened_at": self.link.opened_at,
                "link_loop_work": {"seconds": self.link.loop_work_s,
                                   "messages": self.link.loop_work_messages},
                "clock_offset_configured_s": self.transport.clock.offset,
                "base_offset_s": self.link.offset(self.peer),
                "loop_lateness_s": _percentiles(list(self.runtime.scheduler.lateness or ()))}


class BaseProcess(_Process):
    """The base-station half, built and running (see module docstring)."""

    def __init__(self, stack: NavStack, transport: TransportSection) -> None:
        super().__init__(stack, transport, "follower")
        rt, link, robot = self.runtime, self.link, self.peer
        self.nodes = BaseNodes(rt, stack)
        for name, typ, qos in ROBOT_TOPICS:
            link.import_topic(name, typ, peer=robot, qos=qos)
        for name, typ, qos in BASE_TOPICS:
            link.export_topic(name, typ, qos=qos)
        self.proxies = [ActionProxy(link, action, action, robot)
                        for action in robot_actions(stack)]
        for service in ROBOT_SERVICES:
            proxy_service(link, service, service, robot)
        self.nodes.add_navigator()
        rt.bring_up()

    def wait_for_robot(self, timeout_s: float = 30.0) -> None:
        """Run until the robot's clock is estimated and ``map -> base_link`` is known (in
        lockstep: then on to :data:`MISSION_START_S`, as the in-process reference)."""
        robot = self.peer
        rt = self.runtime
        ok = rt.scheduler.run_for(timeout_s * self.transport.clock.rate, until=lambda: (
            self.link.ready(robot) and rt.tf.can_transform("map", "base_link")))
        if not ok:
            raise ConfigError(f"robot '{robot}' not reachable within {timeout_s:g} s: no "
                              f"clock answer or no map -> base_link (is `navstack robot` "
                              f"running and transport.connect pointing at it?)")
        if self.lockstep is not None:
            rt.scheduler.run_until(self.lockstep.t0 + MISSION_START_S)
        self.nodes.global_costmap.update()

    def run_mission(self, waypoints: list[tuple[str, PoseStamped]],
                    goal_timeout_s: float = 240.0) -> dict[str, Any]:
        """Send each waypoint as a NavigateToPose goal in turn; returns the report."""
        return self.report(drive_mission(self.runtime, waypoints, goal_timeout_s))

    def report(self, goals: list[dict[str, Any]]) -> dict[str, Any]:
        robot = self.peer
        goal_rtt = sorted(x for p in self.proxies for x in p.goal_latency)
        contract = clock_contract(robot, self.link.health()[robot],
                                  self.transport.clock.tolerance)
        return {"role": "base", **self.common_report(), "goals": goals,
                "succeeded": succeeded(goals),
                "goal_round_trip_s": _percentiles(goal_rtt),
                "actions": {p.remote: p.outcomes for p in self.proxies},
                "robot_offset_s": self.link.offset(robot),
                "clock_contract": {"name": contract.name, "ok": contract.ok,
                                   "detail": contract.detail, "fix": contract.fix}}


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

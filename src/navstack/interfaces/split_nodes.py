"""The nodes of the robot / base split, built the same way in two processes or in one.

:func:`robot_nodes` and :func:`base_nodes` build the two halves of a stack file's stack
on a runtime (the robot's command chain: controller -> velocity smoother -> collision
monitor -> twist_mux -> link watchdog -> ``/cmd_vel``).  ``navstack robot`` and
``navstack base`` (:mod:`navstack.interfaces.split`) each build one half and bridge them
over Zenoh; :func:`run_in_process` builds both on one runtime with the in-process bus and
the same seed -- the fair reference of a split run (same nodes, same parameters, same
mission driver :func:`drive_mission`), against which ``navstack split-demo`` and
``navstack bench split`` score the trajectory and the added latency.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from navstack.core.msgs import Header, PoseStamped, Twist
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.costmap.footprint import footprint_cost
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
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime
from navstack.runtime.scheduler import Scheduler
from navstack.runtime.transports.lockstep import SIM_EPOCH
from navstack.sim.node import SimulatorNode
from navstack.sim.simulator import Simulator

#: simulated seconds from the start (both halves up) to the first goal: the same in a
#: lockstep split run and in its in-process reference
MISSION_START_S = 1.0


@dataclass
class ScanToCmd:
    """Scan -> ``/cmd_vel`` latency on one runtime, per command, following the data.

    Every ``/cmd_vel`` that forwards a command the controller computed is traced back
    through the chain (twist_mux / link watchdog -> collision monitor -> velocity
    smoother -> controller cycle -> local costmap update) to the newest scan the local
    costmap had marked when the controller ran; its latency is the clock's reading at
    the ``/cmd_vel`` (real time on a wall clock) minus that scan's stamp, in process
    seconds (divide by the clock rate for real seconds).  Split into ``scheduled``
    (the command's scheduled time minus the stamp: the phases of the scan, costmap,
    controller and smoother timers, the same in every run of the stack) and ``late``
    (how long after its scheduled time the loop got to the command).  One sample per
    controller command, at the first ``/cmd_vel`` that carries it; commands not computed
    from a scan (behaviors, the smoother's repeats, watchdog or mux zeros) are not
    counted."""

    runtime: Runtime
    costmap: CostmapNode
    controller: ControllerServer
    controller_topic: str = "/cmd_vel_nav"
    smoothed_topic: str = "/cmd_vel_smoothed"
    samples: list[float] = field(default_factory=list)
    scheduled: list[float] = field(default_factory=list)
    late: list[float] = field(default_factory=list)
    _cycles: int = 0
    _from_controller: float | None = None
    _pending: float | None = None

    def __post_init__(self) -> None:
        self.runtime.bus.add_tap(self._tap)

    def _tap(self, topic: str, msg: Any, now: float) -> None:
        if topic == self.controller_topic:
            # the controller's cycle publishes at most once; anything else (a behavior,
            # a cancel's stop) was not computed from the costmap
            cycles = self.controller.cycles
            fresh = cycles != self._cycles
            self._cycles = cycles
            self._from_controller = self.costmap.newest_observation if fresh else None
        elif topic == self.smoothed_topic:
            # the first smoothed output carrying a controller command; the smoother's
            # repeats of it (ramping, holding) are not new scan -> command results
            self._pending, self._from_controller = self._from_controller, None
        elif topic == "/cmd_vel" and self._pending is not None:
            stamp, self._pending = self._pending, None
            clock = self.runtime.scheduler.clock()
            self.samples.append(clock - stamp)
            self.scheduled.append(now - stamp)
            self.late.append(clock - now)

    def report(self) -> dict[str, list[float]]:
        """The per-command figures for a run's JSON report (process seconds)."""
        return {"scan_to_cmd_s": self.samples, "scan_to_cmd_scheduled_s": self.scheduled,
                "scan_to_cmd_late_s": self.late}


@dataclass
class RobotNodes:
    """The robot half: simulator, local costmap, controller and behavior servers, the
    command chain and the link watchdog; samples the true pose every 0.1 s."""

    runtime: Runtime
    stack: NavStack
    link_up: Callable[[], bool]
    rows: list[tuple[float, float, float, float]] = field(default_factory=list)
    cmd_log: list[tuple[float, float, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        d, rt = self.stack.description, self.runtime
        simulator = Simulator(d.world, d.robot, d.seed, d.spawn)
        simulator.time = rt.now  # the world starts now on the process clock, not at 0
        self.sim = SimulatorNode(rt, simulator, d.physics_rate_hz, True)
        self.local_costmap = CostmapNode(rt, "local_costmap", d.local_costmap, d.footprint,
                                         d.nav2_file)
        self.controller = ControllerServer(rt, d.controller_server, self.local_costmap,
                                           d.footprint, d.nav2_file)
        self.behaviors = BehaviorServer(rt, d.behavior_server,
                                        collision_checker=self._collides)
        # the command chain as in process, the mux feeding the link watchdog
        self.smoother = VelocitySmootherNode(rt, d.velocity_smoother)
        self.monitor = CollisionMonitorNode(rt, d.body_footprint, d.collision_monitor)
        self.mux = TwistMuxNode(rt, d.twist_mux.model_copy(
            update={"cmd_vel_out": "/cmd_vel_guarded"}))
        self.watchdog = LinkWatchdog(rt, self.link_up)
        rt.bus.subscribe("/cmd_vel", Twist, lambda c: self.cmd_log.append(
            (rt.now, c.linear.x, c.angular.z)), QoS(depth=100))
        self.latency = ScanToCmd(rt, self.local_costmap, self.controller,
                                 self.controller.params.cmd_vel_topic,
                                 self.smoother.params.cmd_vel_out_topic)

    def start_sampling(self) -> None:
        self.runtime.scheduler.create_timer(0.1, self._sample, first_at=self.runtime.now)

    def _collides(self, pose_odom: Any) -> bool:
        cost = footprint_cost(self.local_costmap.costmap,
                              (pose_odom.x, pose_odom.y, pose_odom.theta),
                              self.stack.description.body_footprint)
        return bool(cost == LETHAL_OBSTACLE)

    def _sample(self) -> None:
        self.sim.advance()
        p = self.sim.sim.pose
        self.rows.append((self.runtime.now, p.x, p.y, p.theta))

    @property
    def collisions(self) -> int:
        return self.sim.sim.collisions


@dataclass
class BaseNodes:
    """The base half: map server, global costmap, planner server, BT navigator."""

    runtime: Runtime
    stack: NavStack

    def __post_init__(self) -> None:
        d, rt = self.stack.description, self.runtime
        self.map_server = MapServer(rt, grid=d.map_grid or d.world.to_occupancy_grid())
        self.global_costmap = CostmapNode(rt, "global_costmap", d.global_costmap, d.footprint,
                                          d.nav2_file)
        self.planner = PlannerServer(rt, d.planner_server, self.global_costmap, d.nav2_file,
                                     footprint=d.footprint)

    def add_navigator(self) -> None:
        """The BT navigator (after the action proxies of a split base exist)."""
        d = self.stack.description
        self.navigator = BtNavigator(self.runtime, d.bt_navigator, tree_params=d.navigate_tree)


def _done_of(handle: GoalHandle[Any]) -> Callable[[], bool]:
    return lambda: handle.done


def drive_mission(rt: Runtime, waypoints: list[tuple[str, PoseStamped]],
                  goal_timeout_s: float = 240.0, label: str = "base",
                  echo: bool = True) -> list[dict[str, Any]]:
    """Send each waypoint as a NavigateToPose goal in turn; one record per goal."""
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
        if echo:
            print(f"[{label}] {name}: {status} in {rt.now - t0:.1f} s"
                  + (f" ({result.error_msg})" if result is not None and result.error_msg
                     else ""), flush=True)
    return goals


def succeeded(goals: list[dict[str, Any]]) -> int:
    return sum(g["status"] == GoalStatus.SUCCEEDED.value for g in goals)


def run_in_process(stack_file: str | FsPath, waypoints_file: str | FsPath, *,
                   wall_rate: float | None = None, goal_timeout_s: float = 240.0,
                   echo: bool = False, clock_offset: float = 0.0) -> dict[str, Any]:
    """Both halves of ``stack_file``'s split on one runtime and the in-process bus, with
    the stack's seed: the reference of a split run.  Simulated time starting at
    :data:`~navstack.runtime.transports.lockstep.SIM_EPOCH` like a lockstep robot with no
    clock offset (``wall_rate``: on
    a wall clock at that rate instead, for the latency baseline).  Returns the
    trajectory ``(t, x, y, theta)`` rows, goals, collisions and scan -> cmd_vel
    latencies (process seconds).  ``clock_offset``: start the simulated clock that much
    later -- the clock a lockstep robot with that offset runs on (the mission's outcome
    depends on the clock's start value through float rounding alone)."""
    stack = NavStack.from_stack_file(stack_file)
    waypoints = load_waypoints(waypoints_file)
    sched = (Scheduler("sim", start_time=SIM_EPOCH + clock_offset) if wall_rate is None
             else Scheduler("wall", rate=wall_rate))
    rt = Runtime(sched)
    robot = RobotNodes(rt, stack, lambda: True)
    base = BaseNodes(rt, stack)
    base.add_navigator()
    rt.bring_up()
    robot.start_sampling()
    t0 = rt.now
    rt.scheduler.run_until(t0 + MISSION_START_S)
    base.global_costmap.update()
    goals = drive_mission(rt, waypoints, goal_timeout_s, "in-process", echo)
    return {"role": "in_process", "trajectory": robot.rows, "goals": goals,
            "succeeded": succeeded(goals), "collisions": robot.collisions,
            **robot.latency.report(), "rate": wall_rate or 1.0}


def trajectory_array(rows: list[Any]) -> np.ndarray:
    return np.asarray(rows, dtype=float).reshape(-1, 4)

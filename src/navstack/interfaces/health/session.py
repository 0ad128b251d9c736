"""A health session: a simulated stack, a monitor, an optional fault and a short goal.

What ``navstack check`` and ``navstack doctor --world`` run: build the stack (from a stack
file or a world/robot pair), attach a :class:`~.monitor.HealthMonitor` (and optionally a
:class:`~navstack.runtime.recording.BagRecorder`), inject the fault, send a short goal so
``/cmd_vel`` flows, run the simulation, then report the checks or walk the doctor's tree.

The goal (:func:`pick_goal`) is the first straight, obstacle-free stretch of
``distance`` metres from the robot, trying its heading first and then directions turning
away from it in 45 degree steps, so that a healthy robot drives it with no recovery and
a fault is the only thing that can stop it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from navstack.core.errors import TransformError
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import Pose2D, PoseStamped
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION
from navstack.interfaces.api import Navigator
from navstack.interfaces.health.bag import HEALTH_TOPICS, observations_from_bag
from navstack.interfaces.health.doctor import DoctorReport, diagnose
from navstack.interfaces.health.faults import InjectedFault, inject_fault
from navstack.interfaces.health.model import CheckResult, HealthError, HealthParams
from navstack.interfaces.health.monitor import HealthMonitor
from navstack.interfaces.stack import NavStack
from navstack.runtime.recording import BagRecorder

_TURNS_DEG = (0, 45, -45, 90, -90, 135, -135, 180)


def build_stack(stack_file: str | Path | None = None, world: str = "office",
                robot: str = "diff_drive", seed: int = 0) -> NavStack:
    """The stack a stack file describes, or the default stack on ``world`` with ``robot``."""
    if stack_file is not None:
        return NavStack.from_stack_file(stack_file)
    return NavStack(world, robot, seed=seed)


def wait_until_ready(stack: NavStack, timeout: float = 5.0) -> bool:
    """Run the stack until the robot is localized in the global frame and the global
    costmap knows the robot's cell (SLAM needs a scan or two; AMCL is waited for by
    :class:`NavStack` itself), at most ``timeout`` simulated seconds.  ``True`` if ready."""
    node = stack.global_costmap
    tf = stack.runtime.tf

    def ready() -> bool:
        try:
            pose = tf.lookup_pose2d(node.global_frame, node.robot_base_frame)
        except TransformError:
            return False
        cell = node.costmap.world_to_map(pose.x, pose.y)
        return cell is not None and int(node.costmap.data[cell[1], cell[0]]) != NO_INFORMATION

    done = stack.runtime.scheduler.run_for(timeout, until=ready)
    stack.sim.advance()
    return done


def pick_goal(stack: NavStack, distance: float = 3.0) -> Pose2D:
    """A goal ``distance`` m away in the global frame along a straight line whose cells
    (sampled every half cell) are all below INSCRIBED cost or unknown (a SLAM map that
    has not seen them yet; Nav2's planners ``allow_unknown`` by default)."""
    node = stack.global_costmap
    cm = node.costmap
    try:
        robot = stack.runtime.tf.lookup_pose2d(node.global_frame, node.robot_base_frame)
    except TransformError as exc:
        raise HealthError(f"cannot place a goal: the robot pose in '{node.global_frame}' is "
                          f"unknown ({exc})") from None
    steps = max(2, math.ceil(distance / (0.5 * cm.resolution)))
    s = np.linspace(0.0, distance, steps)
    for lengths in (distance, 0.66 * distance):
        for turn in _TURNS_DEG:
            heading = robot.theta + math.radians(turn)
            xy = np.column_stack((robot.x + s * lengths / distance * math.cos(heading),
                                  robot.y + s * lengths / distance * math.sin(heading)))
            mx, my, ok = cm.world_to_map_array(xy)
            if not ok.all():
                continue
            cost = cm.data[my, mx]
            if bool(np.all((cost < INSCRIBED_INFLATED_OBSTACLE) | (cost == NO_INFORMATION))):
                end = xy[-1]
                return Pose2D(float(end[0]), float(end[1]), normalize_angle(heading))
    raise HealthError(f"no free straight stretch of {0.66 * distance:.1f}-{distance:.1f} m "
                      f"around the robot at ({robot.x:.2f}, {robot.y:.2f}) in the global "
                      f"costmap; move the spawn pose (world.spawn) into open space")


class HealthSession:
    """Stack + monitor (+ recorder) + fault + goal; see the module docstring."""

    def __init__(self, stack: NavStack, params: HealthParams | None = None,
                 fault: str = "healthy", goal: Pose2D | None = None,
                 record: str | Path | None = None, free_travel: float = 0.3,
                 replace: bool = False) -> None:
        """``record``: also write a rosbag2 there (``replace``: over an earlier bag)."""
        self.stack = stack.start()
        self.params = params or HealthParams()
        self.monitor = HealthMonitor(stack, self.params)
        self.recorder = (BagRecorder(stack.runtime, record, HEALTH_TOPICS, replace=replace)
                         if record is not None else None)
        try:
            wait_until_ready(stack)
            self.goal = goal if goal is not None else pick_goal(stack)
            self.fault: InjectedFault = inject_fault(stack, fault, self.goal, free_travel)
        except BaseException:
            self.close()  # a recording stays readable
            raise
        self.navigator = Navigator(stack)
        frame = stack.global_costmap.global_frame
        self.accepted = self.navigator.goToPose(PoseStamped.from_pose2d(self.goal, frame))

    def run(self, seconds: float) -> None:
        """Advance simulated time by ``seconds``."""
        self.stack.run_for(seconds)

    def report(self) -> list[CheckResult]:
        """The monitor's checks now (see :meth:`HealthMonitor.report`)."""
        return self.monitor.report()

    def diagnose(self) -> DoctorReport:
        """The doctor's walk over everything observed since the session began."""
        obs = self.monitor.observations(span=math.inf)
        obs.source = (f"simulated run ({self.fault.name}: {self.fault.description}, goal "
                      f"({self.goal.x:.2f}, {self.goal.y:.2f}))")
        return diagnose(obs, self.params)

    def close(self) -> None:
        """Stop observing and finish the recording (if any)."""
        self.monitor.close()
        if self.recorder is not None:
            self.recorder.close()


def diagnose_bag(path: str | Path, params: HealthParams | None = None) -> DoctorReport:
    """The doctor's walk over a recorded run (``navstack doctor --bag``)."""
    return diagnose(observations_from_bag(path), params)

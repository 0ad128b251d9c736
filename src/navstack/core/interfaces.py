"""The plugin interfaces the servers load (navstack's ``nav2_core``).

Each is as small as its ``nav2_core`` counterpart and declares its parameter model as
the class attribute ``params_model``, so a server validates a plugin's YAML section
before building it, with errors naming the file and key path::

    cls = PLANNERS.get("nav2_navfn_planner/NavfnPlanner")   # navstack.core.plugins
    planner = cls(cls.params_model.from_mapping(section, file=..., key_path=...))

Construction takes the validated params (controllers also the robot ``footprint``);
everything a plugin needs per call comes in the call, in the costmap's frame.

================  ====================================================================
interface         contract (Nav2 counterpart)
================  ====================================================================
GlobalPlanner     ``configure(costmap, footprint)``; ``plan(start, goal, costmap,
                  cancel=None) -> Path`` raising the typed ``PlannerError`` subclasses
                  (``nav2_core::GlobalPlanner``)
Controller        ``set_plan(path)``; ``compute(pose, velocity, path, costmap, now) ->
                  Twist2D`` raising ``ControllerError``; ``set_speed_limit(limit,
                  percentage)``; ``reset()`` (``nav2_core::Controller``)
Smoother          ``smooth(path, costmap=None, max_time=None) -> Path``
                  (``nav2_core::Smoother``)
GoalChecker       ``is_goal_reached(pose, goal, velocity) -> bool``; ``reset()``
ProgressChecker   ``check(pose, now, goal=None) -> bool``; ``reset()``
Behavior          ``start(goal, pose, now)``; ``cycle(pose, now) -> BehaviorStep``;
                  ``projection(...)`` for the collision check (``nav2_core::Behavior`` /
                  ``TimedBehavior``)
================  ====================================================================

Family-specific interfaces live with their family, as in Nav2: the costmap layer
(:class:`navstack.costmap.layer.Layer`, Nav2 ``nav2_costmap_2d::Layer``), DWB critics
(:class:`navstack.control.dwb.critic_base.TrajectoryCritic`, ``dwb_core``) and MPPI
critics (:class:`navstack.control.mppi.critics.base.Critic`, ``nav2_mppi_controller``).
``Costmap2D`` and ``LayeredCostmap`` appear here in annotations only: core imports
nothing above it at run time.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.params import Params
from navstack.core.polygon import Footprint

if TYPE_CHECKING:
    from navstack.costmap.costmap_2d import Costmap2D
    from navstack.costmap.layered_costmap import LayeredCostmap

CancelFn = Callable[[], bool]
"""Polled by planners between search chunks; True cancels (``PlannerCancelled``)."""

G = TypeVar("G")


class NoParams(Params):
    """The params model of a plugin without parameters (an empty section)."""


class GlobalPlanner(ABC):
    """A global planner plugin (``nav2_core::GlobalPlanner``)."""

    params_model: ClassVar[type[Params]] = NoParams

    def __init__(self, params: Params | None = None) -> None:
        self.params: Params = params if params is not None else self.params_model()

    def configure(self, costmap: LayeredCostmap, footprint: Footprint) -> None:  # noqa: B027  (optional hook)
        """Called once by the planner server with its costmap and the robot's (padded)
        footprint (Nav2 ``configure``); planners that check the body or read the
        inflation layer keep what they need.  Default: nothing."""

    simulated_time: bool = False
    """The clock is simulated: a ``max_planning_time`` becomes a fixed expansion budget
    (:mod:`navstack.planning.budget`) instead of a wall-clock deadline."""

    def use_simulated_time(self, simulated: bool) -> None:
        """Told by the planner server whether its clock is simulated (stepped) time.

        Planners with a wall-clock budget (``max_planning_time``) then count it in
        expansions, so a seed plans the same on any machine; on the wall clock (a robot,
        a notebook) they keep Nav2's deadline.  Planners without one ignore it."""
        self.simulated_time = simulated

    @abstractmethod
    def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap2D,
             cancel: CancelFn | None = None) -> Path:
        """A path from ``start`` to ``goal`` (both in ``costmap.frame_id``).

        Raises ``StartOutsideMap``, ``GoalOutsideMap``, ``StartOccupied``,
        ``GoalOccupied``, ``NoValidPath``, ``PlannerTimeout`` or ``PlannerCancelled``
        (``navstack.core.errors``); the planner server maps each to Nav2's error code.
        """


class Controller(ABC):
    """A local controller plugin (``nav2_core::Controller``)."""

    params_model: ClassVar[type[Params]] = NoParams

    def __init__(self, params: Params | None = None, *,
                 footprint: Footprint | None = None) -> None:
        self.params: Params = params if params is not None else self.params_model()
        self.footprint = footprint

    @abstractmethod
    def set_plan(self, path: Path) -> None:
        """Take a new global plan, in the costmap frame (Nav2 ``setPlan``)."""

    @abstractmethod
    def compute(self, pose: Pose2D, velocity: Twist2D, path: Path | None,
                costmap: Costmap2D, now: float = 0.0) -> Twist2D:
        """The velocity command for this cycle (``computeVelocityCommands``).

        ``pose``, ``path`` in ``costmap.frame_id``; ``velocity`` the measured body
        twist; a ``path`` other than the current plan acts as :meth:`set_plan`, ``None``
        keeps it.  Raises ``NoValidControl`` / ``InvalidPath`` (``ControllerError``).
        """

    @abstractmethod
    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2 speed limit: ``0`` removes it; else ``limit`` percent of the maximum
        speed (``percentage``) or an absolute ``limit`` [m/s]."""

    @abstractmethod
    def reset(self) -> None:
        """Forget per-goal state (Nav2 ``reset``)."""


class Smoother(ABC):
    """A path smoother plugin (``nav2_core::Smoother``)."""

    params_model: ClassVar[type[Params]] = NoParams

    def __init__(self, params: Params | None = None) -> None:
        self.params: Params = params if params is not None else self.params_model()

    @abstractmethod
    def smooth(self, path: Path, costmap: Costmap2D | None = None,
               max_time: float | None = None) -> Path:
        """The smoothed path, same frame; ``costmap`` enables collision checks,
        ``max_time`` [s] raises ``PlannerTimeout`` when exceeded."""


class GoalChecker(ABC):
    """Is the goal reached? (``nav2_core::GoalChecker``)."""

    params_model: ClassVar[type[Params]] = NoParams

    def __init__(self, params: Params | None = None) -> None:
        self.params: Params = params if params is not None else self.params_model()

    @abstractmethod
    def is_goal_reached(self, pose: Pose2D, goal: Pose2D, velocity: Twist2D) -> bool:
        """``pose`` and ``goal`` in the same frame; ``velocity`` the body twist."""

    def reset(self) -> None:  # noqa: B027  (optional hook)
        """Forget latched state (new goal).  Default: nothing."""


class ProgressChecker(ABC):
    """Is the robot still getting somewhere? (``nav2_core::ProgressChecker``)."""

    params_model: ClassVar[type[Params]] = NoParams

    def __init__(self, params: Params | None = None) -> None:
        self.params: Params = params if params is not None else self.params_model()

    @abstractmethod
    def check(self, pose: Pose2D, now: float, goal: Pose2D | None = None) -> bool:
        """False once the robot made no progress for too long.  ``now`` [s] is the
        caller's clock; ``goal`` (same frame as ``pose``) is for goal-based checkers,
        movement-based ones ignore it (Nav2's interface has only the pose)."""

    @abstractmethod
    def reset(self) -> None:
        """Restart the baseline (new goal)."""

    def failure_message(self) -> str:
        """What "no progress" means for this checker, for the FollowPath abort reason."""
        return f"{type(self).__name__} saw no progress"


@dataclass(frozen=True)
class BehaviorStep:
    """One behavior cycle: the twist to publish (``None``: publish nothing), the
    progress value for feedback (angle turned, distance, time left...) and whether the
    behavior is done."""

    twist: Twist2D | None
    progress: float
    done: bool = False


class Behavior(ABC, Generic[G]):
    """A recovery behavior of the behavior server (``nav2_core::Behavior`` with
    ``TimedBehavior``'s cycle), serving the action named after its plugin name.

    ``goal_type`` is the action goal dataclass it accepts.  One instance serves all
    goals of its action: :meth:`start` begins a goal, :meth:`cycle` runs at the
    server's ``cycle_frequency`` until it reports ``done``.
    """

    params_model: ClassVar[type[Params]] = NoParams
    goal_type: ClassVar[type[object]] = object

    def __init__(self, params: Params | None = None) -> None:
        self.params: Params = params if params is not None else self.params_model()

    @abstractmethod
    def start(self, goal: G, pose: Pose2D, now: float) -> None:
        """Begin ``goal`` from ``pose`` (``local_frame``) at ``now`` (Nav2 ``onRun``);
        raise :class:`~navstack.core.errors.InvalidBehaviorGoal` for a bad field."""

    @abstractmethod
    def cycle(self, pose: Pose2D, now: float) -> BehaviorStep:
        """One control cycle (Nav2 ``onCycleUpdate``)."""

    def projection(self, pose: Pose2D, twist: Twist2D, steps: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        """``(K, 3)`` poses the robot would reach after ``steps`` [s] of ``twist``,
        stopping where the behavior would end; each is collision-checked before the
        twist is published.  Default: none (a behavior that does not move)."""
        return np.zeros((0, 3))

    @property
    def time_allowance(self) -> float:
        """Seconds the current goal may take; 0 = unlimited."""
        return 0.0

    @property
    @abstractmethod
    def progress(self) -> float:
        """The current progress value (reported in the result when the goal ends)."""

    @property
    @abstractmethod
    def description(self) -> str:
        """What the current goal does, for messages (``"spinning 1.57 rad"``)."""

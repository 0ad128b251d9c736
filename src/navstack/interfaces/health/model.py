"""Data of the health layer: parameters, check results, diagnoses and the observations
every check reads.

The observability contract (ARCHITECTURE.md §3, the textbook lab): every failure of the
navigation pipeline has measurable symptoms.  :class:`Observations` is that measurement,
in one shape whether it comes from a running bus (:class:`~.monitor.HealthMonitor`) or a
recorded bag (:func:`~.bag.observations_from_bag`), so the checks and the doctor's
decision tree are written once.  Fields a bag cannot hold (lifecycle states, controller
parameters) are ``None`` there and the checks say what they inferred instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.errors import NavstackError
from navstack.core.params import Params
from navstack.core.tf import TransformTree

FloatArray = NDArray[np.float64]


class HealthError(NavstackError):
    """A health session cannot run (no goal to send, a fault that does not apply, ...)."""


class HealthParams(Params):
    """Bounds of the health checks.

    * ``window`` [s]: span over which topic rates are measured (diagnostic_updater's
      ``FrequencyStatus`` window, in seconds instead of samples);
    * ``rate_tolerance``: a topic passes when it delivered at least
      ``(1 - rate_tolerance) * expected_rate * window`` messages (diagnostic_updater's
      ``tolerance``, 0.1 there; 0.2 here so a wall-clock run with scheduling jitter passes);
    * ``transform_tolerance`` [s]: largest age of the newest sample of a dynamic TF edge
      (Nav2 ``Costmap2DROS`` ``transform_tolerance``, default 0.3 s);
    * ``lethal_fraction``: a costmap whose known cells are lethal or inscribed in at
      least this fraction is "all lethal" (nothing can be planned or followed in it);
    * ``max_position_std`` [m], ``max_yaw_std`` [rad]: bound on the localization
      estimate's standard deviations (``/amcl_pose``, ``/odometry/filtered``);
    * ``required_movement_radius`` [m], ``movement_time_allowance`` [s]: the progress
      rule (Nav2 ``SimpleProgressChecker`` defaults) used when the controller's own
      checker is not available (bags);
    * ``min_cmd_linear`` [m/s], ``min_cmd_angular`` [rad/s]: commands below both are
      "zero"; ``follow_ratio``: the base follows a command when its measured twist has
      the command's sign and at least this fraction of its size ``response_lag`` [s]
      later; ``min_followed``: commands followed to show that the base consumes
      ``/cmd_vel`` (5 = a quarter of a second at the controller's 20 Hz).
    """

    window: float = Field(2.0, gt=0.0)
    rate_tolerance: float = Field(0.2, ge=0.0, lt=1.0)
    transform_tolerance: float = Field(0.3, gt=0.0)
    lethal_fraction: float = Field(0.9, gt=0.0, le=1.0)
    max_position_std: float = Field(0.5, gt=0.0)
    max_yaw_std: float = Field(0.5, gt=0.0)
    required_movement_radius: float = Field(0.5, ge=0.0)
    movement_time_allowance: float = Field(10.0, gt=0.0)
    min_cmd_linear: float = Field(0.05, ge=0.0)
    min_cmd_angular: float = Field(0.1, ge=0.0)
    follow_ratio: float = Field(0.3, gt=0.0, le=1.0)
    response_lag: float = Field(0.2, ge=0.0)
    min_followed: int = Field(5, ge=1)


@dataclass(frozen=True)
class CheckResult:
    """One health check: ``ok``, what was measured (``detail``) and how to fix a failure."""

    name: str
    ok: bool
    detail: str
    fix: str = ""


@dataclass(frozen=True)
class Diagnosis:
    """The doctor's verdict: the broken ``contract``, the ``evidence`` and the ``fix``.

    ``contract`` is ``"none"`` when every contract held."""

    contract: str
    evidence: str
    fix: str


@dataclass(frozen=True)
class GoalSpan:
    """One navigation goal: accepted at ``start``, ended at ``end`` (``None``: running)."""

    start: float
    end: float | None = None
    status: str = "EXECUTING"
    error_code: int = 0
    reason: str = ""

    def active_at(self, t: float) -> bool:
        return self.start <= t and (self.end is None or t <= self.end)


@dataclass(frozen=True)
class CostmapSnapshot:
    """What the costmap checks need of one costmap.

    ``blocked_fraction``: share of known cells that are lethal or inscribed;
    ``robot_cost``: the cost under the robot (footprint maximum live, centre cell from a
    bag's OccupancyGrid), ``None`` when the robot pose is unknown; ``robot_lethal``
    whether that cost means the robot is in collision."""

    name: str
    frame: str
    known_cells: int
    blocked_fraction: float
    robot_cost: int | None
    robot_lethal: bool


@dataclass
class Observations:
    """What the checks read, over the span ``[start, now]`` (see the module docstring).

    Arrays: ``cmd`` rows ``(t, vx, wz)`` of ``/cmd_vel``; ``odom`` rows
    ``(t, x, y, yaw, vx, wz)`` of ``/odom`` (``odom`` frame, body twist); ``tf_samples``
    maps a dynamic edge ``"parent->child"`` to rows ``(publish time, stamp)``.
    """

    source: str
    start: float
    now: float
    topic_times: dict[str, FloatArray] = field(default_factory=dict)
    expected_rates: dict[str, float] = field(default_factory=dict)
    latched: dict[str, bool] = field(default_factory=dict)
    cmd: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    odom: FloatArray = field(default_factory=lambda: np.zeros((0, 6)))
    tf: TransformTree = field(default_factory=TransformTree)
    tf_samples: dict[str, FloatArray] = field(default_factory=dict)
    global_frame: str = "map"
    odom_frame: str = "odom"
    base_frame: str = "base_link"
    sensor_frames: tuple[str, ...] = ()
    goals: list[GoalSpan] = field(default_factory=list)
    plans: list[tuple[float, str]] = field(default_factory=list)
    costmaps: list[CostmapSnapshot] = field(default_factory=list)
    covariance: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))
    covariance_topic: str = ""
    follow_path_failures: list[tuple[float, int, str]] = field(default_factory=list)
    node_states: dict[str, str] | None = None
    controller_node: str = "controller_server"
    velocity_limits: dict[str, float] | None = None
    progress_rule: tuple[float, float] | None = None
    base_subscribers: int | None = None
    notes: list[str] = field(default_factory=list)

    def goal_intervals(self) -> list[tuple[float, float]]:
        """``[start, end]`` of each goal clipped to the observed span (running: to now)."""
        out = []
        for g in self.goals:
            lo, hi = max(g.start, self.start), min(g.end if g.end is not None else self.now,
                                                   self.now)
            if hi > lo:
                out.append((lo, hi))
        return out

"""DWB parameters with Nav2's names, in Nav2's flat ``FollowPath`` layout.

Nav2 reads the DWB controller, its trajectory generator (``KinematicParameters``,
``XYThetaIterator``, ``StandardTrajectoryGenerator``) and its critics all from one
namespace: ``FollowPath.max_vel_x``, ``FollowPath.vx_samples``,
``FollowPath.PathAlign.scale``...  :class:`DWBParams` mirrors that: generator and
kinematic keys are plain fields, and critic keys (``PathAlign.scale`` written dotted or
as a nested ``PathAlign: {scale: ...}`` mapping) are gathered into ``critic_params`` and
validated by each critic's own model when the controller is built.

Defaults.  Nav2's C++ defaults for the velocity and acceleration limits are all 0.0,
which leaves a robot that cannot move; navstack uses the values of Nav2's shipped
``nav2_params.yaml`` (TurtleBot3-class robot) instead: ``max_vel_x 0.26``,
``max_vel_theta 1.0``, ``acc_lim_x 2.5``, ``acc_lim_theta 3.2``,
``decel_lim_x -2.5``, ``decel_lim_theta -3.2``, ``linear_granularity 0.05``.  Everything
else is Nav2's code default.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Self

from pydantic import Field, model_validator

from navstack.core.errors import ConfigError
from navstack.core.params import Params

DEFAULT_CRITICS: tuple[str, ...] = (
    "RotateToGoal", "Oscillation", "BaseObstacle", "GoalAlign", "PathAlign", "PathDist",
    "GoalDist",
)
"""Nav2's DWB critic list (``nav2_params.yaml``), in evaluation order."""


class KinematicParameters(Params):
    """``dwb_plugins::KinematicParameters``: velocity and acceleration limits.

    Deceleration limits are negative, as in Nav2 (``decel_lim_x: -2.5``); the minimum
    angular velocity is ``-max_vel_theta``.  ``max_speed_xy`` bounds the planar speed
    ``hypot(vx, vy)``; ``min_speed_xy``/``min_speed_theta`` reject samples that are
    slower than both (a negative value disables the check).
    """

    min_vel_x: float = 0.0
    min_vel_y: float = 0.0
    max_vel_x: float = 0.26
    max_vel_y: float = 0.0
    max_vel_theta: float = Field(1.0, ge=0.0)
    min_speed_xy: float = 0.0
    max_speed_xy: float = 0.26
    min_speed_theta: float = 0.0
    acc_lim_x: float = Field(2.5, ge=0.0)
    acc_lim_y: float = Field(0.0, ge=0.0)
    acc_lim_theta: float = Field(3.2, ge=0.0)
    decel_lim_x: float = Field(-2.5, le=0.0)
    decel_lim_y: float = Field(0.0, le=0.0)
    decel_lim_theta: float = Field(-3.2, le=0.0)

    @model_validator(mode="after")
    def _check_ranges(self) -> Self:
        for axis in ("x", "y"):
            lo, hi = getattr(self, f"min_vel_{axis}"), getattr(self, f"max_vel_{axis}")
            if lo > hi:
                raise ValueError(f"min_vel_{axis} ({lo}) must not exceed max_vel_{axis} ({hi})")
        return self


class TrajectoryGeneratorParams(KinematicParameters):
    """``dwb_plugins::StandardTrajectoryGenerator`` + ``XYThetaIterator`` parameters.

    ``sim_period`` is the acceleration time of the dynamic window: samples are the
    velocities reachable from the current one within one controller period (Nav2's
    ``LimitedAccelGenerator`` reads it as ``sim_period`` or ``1/controller_frequency``,
    default 20 Hz -> 0.05 s).  Setting ``sim_period`` equal to ``sim_time`` reproduces
    Nav2's ``StandardTrajectoryGenerator`` window, which spans the whole velocity range.
    """

    vx_samples: int = Field(20, ge=1)
    vy_samples: int = Field(5, ge=1)
    vtheta_samples: int = Field(20, ge=1)
    sim_time: float = Field(1.7, gt=0.0)
    sim_period: float = Field(0.05, gt=0.0)
    linear_granularity: float = Field(0.05, gt=0.0)
    angular_granularity: float = Field(0.025, gt=0.0)
    include_last_point: bool = True
    discretize_by_time: bool = False
    time_granularity: float = Field(0.5, gt=0.0)


class DWBParams(TrajectoryGeneratorParams):
    """``dwb_core::DWBLocalPlanner`` parameters (plus the generator's, flat as in Nav2).

    ``debug_trajectory_details`` scores every sample with every critic (no dropping of
    rejected samples) so :attr:`DWBLocalPlanner.last_evaluation` holds the full score
    table; the command is the same either way.
    ``transform_tolerance`` and ``stateful`` are accepted so Nav2 parameter files load;
    navstack's DWB is pure (the caller transforms pose and path into the costmap frame)
    and the goal checker owns ``stateful``, so both are unused here.
    """

    plugin: str = "dwb_core::DWBLocalPlanner"
    critics: tuple[str, ...] = DEFAULT_CRITICS
    default_critic_namespaces: tuple[str, ...] = ("dwb_critics",)
    trajectory_generator_name: str = "dwb_plugins::StandardTrajectoryGenerator"
    prune_plan: bool = True
    prune_distance: float = Field(2.0, gt=0.0)
    forward_prune_distance: float = Field(2.0, gt=0.0)
    shorten_transformed_plan: bool = True
    debug_trajectory_details: bool = False
    short_circuit_trajectory_evaluation: bool = True
    transform_tolerance: float = 0.1
    stateful: bool = True
    xy_goal_tolerance: float = Field(0.25, ge=0.0)
    trans_stopped_velocity: float = Field(0.25, ge=0.0)
    critic_params: dict[str, dict[str, Any]] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _check_critics(self) -> Self:
        if len(set(self.critics)) != len(self.critics):
            raise ValueError(f"critics lists a name twice: {list(self.critics)}")
        unknown = sorted(set(self.critic_params) - set(self.critics))
        if unknown:
            raise ValueError(
                f"parameters given for critic(s) {unknown} that are not in critics "
                f"{list(self.critics)}; add them to critics or remove their keys")
        return self

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Validate a Nav2-layout mapping; critic keys may be dotted or nested."""
        flat = dict(data or {})
        fields = set(cls.model_fields)
        critic_names = set(flat.get("critics", DEFAULT_CRITICS))
        sections: dict[str, dict[str, Any]] = {
            k: dict(v) for k, v in dict(flat.pop("critic_params", {}) or {}).items()}
        for key in list(flat):
            value = flat[key]
            if "." in key:
                head, tail = key.split(".", 1)
                if head in critic_names or head not in fields:
                    sections.setdefault(head, {})[tail] = flat.pop(key)
            elif key not in fields and key in critic_names:
                if not isinstance(value, Mapping):
                    raise ConfigError(
                        f"critic section must be a mapping of parameters, got {value!r}",
                        file=file, key_path=f"{key_path}.{key}" if key_path else key)
                sections.setdefault(key, {}).update(flat.pop(key))
        if sections:
            flat["critic_params"] = sections
        return super().from_mapping(flat, file=file, key_path=key_path)

"""Per-critic parameter sections of the MPPI controller (Nav2 ``mppi::critics``).

Each class mirrors one Nav2 critic's ``initialize()``: the same keys and the same code
defaults (Nav2 Jazzy, ``nav2_mppi_controller/src/critics/*.cpp``).  In a Nav2 YAML file
a section sits next to the controller keys under the critic's name::

    FollowPath:
      critics: ["ConstraintCritic", "GoalCritic"]
      GoalCritic: {enabled: true, cost_power: 1, cost_weight: 5.0, threshold_to_consider: 1.4}

Every critic has ``enabled`` (default true, ``CriticFunction::on_configure``); the
cost-term critics have ``cost_weight`` and ``cost_power`` (the term is
``(weight * raw) ** power``); goal/path critics gate themselves with
``threshold_to_consider`` [m] (distance from the robot to the goal).

navstack additions, documented where they appear: ``inflation_radius`` and
``cost_scaling_factor`` on CostCritic/ObstaclesCritic (Nav2 Humble's ObstaclesCritic
fallback keys) stand in for the inflation layer Nav2 looks up in the costmap, since a
navstack controller receives a plain :class:`~navstack.costmap.costmap_2d.Costmap2D`;
``forward_preference`` on PathAngleCritic is Nav2 Humble's key, mapped onto Jazzy's
``mode``.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field, model_validator

from navstack.core.params import Params


class CriticParams(Params):
    """Keys every critic has (``CriticFunction``): ``enabled``."""

    enabled: bool = True


class WeightedCriticParams(CriticParams):
    """A critic whose term is ``(cost_weight * raw) ** cost_power``."""

    cost_power: int = Field(1, ge=1)
    cost_weight: float = Field(1.0, ge=0.0)


class ConstraintCriticParams(WeightedCriticParams):
    """``ConstraintCritic``: penalises sampled velocities outside ``vx_min..vx_max``
    (and ``|vy| > vy_max`` for Omni, turning radius below ``min_turning_r`` for
    Ackermann), integrated over time (``sum(violation) * model_dt``)."""

    cost_weight: float = Field(4.0, ge=0.0)


class _CollisionCriticParams(CriticParams):
    """Keys shared by the two costmap critics."""

    consider_footprint: bool = False
    near_goal_distance: float = Field(0.5, ge=0.0)
    inflation_layer_name: str = ""
    inflation_radius: float = Field(0.55, ge=0.0)
    cost_scaling_factor: float = Field(10.0, ge=0.0)


class CostCriticParams(_CollisionCriticParams):
    """``CostCritic``: sums costmap cost along every ``trajectory_point_step``-th pose.

    Poses at or above ``near_collision_cost`` add ``critical_cost``; a collision (LETHAL,
    INSCRIBED for a point robot, unknown unless the costmap tracks unknown space) replaces
    the sum with ``collision_cost``.  The term is ``(sum * cost_weight / 254 / n) **
    cost_power`` with ``n`` the number of evaluated poses.  Within ``near_goal_distance``
    of the goal only critical and collision costs count.
    """

    cost_power: int = Field(1, ge=1)
    cost_weight: float = Field(3.81, ge=0.0)
    critical_cost: float = Field(300.0, ge=0.0)
    near_collision_cost: int = Field(253, ge=1, le=255)
    collision_cost: float = Field(1000000.0, ge=0.0)
    trajectory_point_step: int = Field(2, ge=1)


class ObstaclesCriticParams(_CollisionCriticParams):
    """``ObstaclesCritic``: distance-to-obstacle terms recovered from inflated cost.

    ``distance = (k * r_inscribed - ln(cost) + ln(253)) / k`` (minus ``r_inscribed`` for
    a point check), ``k = cost_scaling_factor``.  Poses closer than
    ``collision_margin_distance`` add ``margin - distance`` (scaled by
    ``critical_weight``); every inflated pose adds ``inflation_radius - distance``
    (scaled by ``repulsion_weight``, normalised by the batch minimum and the horizon).
    A colliding trajectory scores ``critical_weight * collision_cost``.
    """

    cost_power: int = Field(1, ge=1)
    repulsion_weight: float = Field(1.5, ge=0.0)
    critical_weight: float = Field(20.0, ge=0.0)
    collision_cost: float = Field(100000.0, ge=0.0)
    collision_margin_distance: float = Field(0.10, ge=0.0)


class GoalCriticParams(WeightedCriticParams):
    """``GoalCritic``: mean distance of the trajectory poses to the goal, active once the
    robot is within ``threshold_to_consider`` of it."""

    cost_weight: float = Field(5.0, ge=0.0)
    threshold_to_consider: float = Field(1.4, ge=0.0)


class GoalAngleCriticParams(WeightedCriticParams):
    """``GoalAngleCritic``: mean |yaw - goal yaw| over the trajectory, active within
    ``threshold_to_consider``; ``symmetric_yaw_tolerance`` also accepts goal yaw + pi."""

    cost_weight: float = Field(3.0, ge=0.0)
    threshold_to_consider: float = Field(0.5, ge=0.0)
    symmetric_yaw_tolerance: bool = False


class PathAlignCriticParams(WeightedCriticParams):
    """``PathAlignCritic``: mean distance of every ``trajectory_point_step``-th pose to
    the path point at the same arc length; skipped near the goal, before trajectories
    reach ``offset_from_furthest`` path points, or when more than
    ``max_path_occupancy_ratio`` of the path is blocked."""

    cost_weight: float = Field(10.0, ge=0.0)
    max_path_occupancy_ratio: float = Field(0.07, ge=0.0, le=1.0)
    offset_from_furthest: int = Field(20, ge=0)
    trajectory_point_step: int = Field(4, ge=1)
    threshold_to_consider: float = Field(0.5, ge=0.0)
    use_path_orientations: bool = False


class PathFollowCriticParams(WeightedCriticParams):
    """``PathFollowCritic``: distance of the trajectory end to the first valid path
    point ``offset_from_furthest`` points beyond the furthest one reached."""

    cost_weight: float = Field(5.0, ge=0.0)
    offset_from_furthest: int = Field(6, ge=0)
    threshold_to_consider: float = Field(1.4, ge=0.0)


class PathAngleCriticParams(WeightedCriticParams):
    """``PathAngleCritic``: heading error of the trajectory end towards the path point
    ``offset_from_furthest`` beyond the furthest reached, active when the robot's own
    heading is off by more than ``max_angle_to_furthest``.

    ``mode``: 0 forward preference, 1 no directional preference, 2 consider the path's
    orientations (feasible planners).  ``forward_preference`` (Nav2 Humble) maps to
    mode 0 (true) or 1 (false) when given.
    """

    cost_weight: float = Field(2.2, ge=0.0)
    offset_from_furthest: int = Field(4, ge=0)
    threshold_to_consider: float = Field(0.5, ge=0.0)
    max_angle_to_furthest: float = Field(0.785398, ge=0.0)
    mode: int = Field(0, ge=0, le=2)
    forward_preference: bool | None = None

    @model_validator(mode="before")
    @classmethod
    def _humble_forward_preference(cls, data: Any) -> Any:
        if isinstance(data, dict) and isinstance(data.get("forward_preference"), bool):
            data = {**data, "mode": 0 if data["forward_preference"] else 1}
        return data


class PreferForwardCriticParams(WeightedCriticParams):
    """``PreferForwardCritic``: integrated reverse speed ``sum(max(-vx, 0)) * dt``,
    active farther than ``threshold_to_consider`` from the goal."""

    cost_weight: float = Field(5.0, ge=0.0)
    threshold_to_consider: float = Field(0.5, ge=0.0)


class TwirlingCriticParams(WeightedCriticParams):
    """``TwirlingCritic``: mean |wz| over the trajectory, off within the goal checker's
    xy tolerance (navstack: the controller's ``xy_goal_tolerance``)."""

    cost_weight: float = Field(10.0, ge=0.0)


class VelocityDeadbandCriticParams(WeightedCriticParams):
    """``VelocityDeadbandCritic``: integrated shortfall below ``deadband_velocities``
    ``[vx, vy, wz]`` (robots that cannot move slower than a threshold)."""

    cost_weight: float = Field(35.0, ge=0.0)
    deadband_velocities: tuple[float, float, float] = (0.0, 0.0, 0.0)


CRITIC_PARAMS: dict[str, type[CriticParams]] = {
    "ConstraintCritic": ConstraintCriticParams,
    "CostCritic": CostCriticParams,
    "ObstaclesCritic": ObstaclesCriticParams,
    "GoalCritic": GoalCriticParams,
    "GoalAngleCritic": GoalAngleCriticParams,
    "PathAlignCritic": PathAlignCriticParams,
    "PathFollowCritic": PathFollowCriticParams,
    "PathAngleCritic": PathAngleCriticParams,
    "PreferForwardCritic": PreferForwardCriticParams,
    "TwirlingCritic": TwirlingCriticParams,
    "VelocityDeadbandCritic": VelocityDeadbandCriticParams,
}
"""Critic class name (as written in ``critics``) -> its parameter model."""

"""Regulated Pure Pursuit parameters (Nav2 names and Jazzy defaults).

Every field of Nav2's ``nav2_regulated_pure_pursuit_controller`` parameter handler is
here with its default.  Three navstack additions stand in for values Nav2 reads from
elsewhere or lacks:

* ``controller_frequency`` (20 Hz): Nav2 reads it from the controller server; it sets the
  time step of the rotate-to-heading acceleration limit and of cancel deceleration;
* ``xy_goal_tolerance`` (0.25 m): Nav2 asks the goal checker; within it of the path end
  the robot rotates to the goal heading (``use_rotate_to_heading``);
* ``min_turning_radius`` (0 = none): for car-like (Ackermann) robots the commanded
  curvature is clamped to ``1 / min_turning_radius``; Nav2 has no such limit and relies on
  a kinematically feasible path.  A car cannot turn in place, so ``min_turning_radius > 0``
  requires ``use_rotate_to_heading: false``;
* ``back_out_speed`` (0 = off, Nav2's behaviour) and ``back_out_max_distance`` (0.3 m, the
  BackUp recovery's default distance): when the turn in place toward the path is blocked
  both ways (the footprint would reach lethal cost turning either way round), back
  straight out at ``back_out_speed`` [m/s] while the reverse projection is free, up to
  ``back_out_max_distance`` per turn, instead of failing the goal for the navigator's
  BackUp recovery -- a forward-only robot whose tail swings into a wall (the TurtleBot3
  Waffle Pi) then answers a new goal at once (docs/decisions.md, "In-place turns judged
  by their sweep").

``use_interpolation`` (Humble; removed later, when it became always on) chooses whether
the carrot is interpolated on the path segment crossing the lookahead circle or is the
first pose beyond it.  ``max_robot_pose_search_dist`` left unset means half the costmap's
x size, as Nav2; a negative value searches the whole path.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Self

from pydantic import Field, model_validator

from navstack.core.errors import ConfigError
from navstack.core.params import Params


class _CrossFieldError(ConfigError):
    """A rule between fields failed; re-raised with file and key path by from_mapping."""


class RegulatedPurePursuitParams(Params):
    """``nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController`` params."""

    plugin: str = "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
    desired_linear_vel: float = Field(0.5, gt=0.0)
    lookahead_dist: float = Field(0.6, gt=0.0)
    min_lookahead_dist: float = Field(0.3, gt=0.0)
    max_lookahead_dist: float = Field(0.9, gt=0.0)
    lookahead_time: float = Field(1.5, gt=0.0)
    rotate_to_heading_angular_vel: float = Field(1.8, gt=0.0)
    transform_tolerance: float = Field(0.1, ge=0.0)
    """Accepted for Nav2 files; the caller transforms pose and path (pure controller)."""
    use_velocity_scaled_lookahead_dist: bool = False
    min_approach_linear_velocity: float = Field(0.05, ge=0.0)
    approach_velocity_scaling_dist: float = Field(0.6, ge=0.0)
    use_collision_detection: bool = True
    max_allowed_time_to_collision_up_to_carrot: float = Field(1.0, ge=0.0)
    use_regulated_linear_velocity_scaling: bool = True
    use_cost_regulated_linear_velocity_scaling: bool = True
    cost_scaling_dist: float = Field(0.6, gt=0.0)
    cost_scaling_gain: float = Field(1.0, ge=0.0)
    inflation_cost_scaling_factor: float = 3.0
    regulated_linear_scaling_min_radius: float = Field(0.9, gt=0.0)
    regulated_linear_scaling_min_speed: float = Field(0.25, ge=0.0)
    use_fixed_curvature_lookahead: bool = False
    curvature_lookahead_dist: float = Field(0.6, gt=0.0)
    use_rotate_to_heading: bool = True
    allow_reversing: bool = False
    rotate_to_heading_min_angle: float = Field(0.785, ge=0.0)
    max_angular_accel: float = Field(3.2, gt=0.0)
    max_robot_pose_search_dist: float | None = None
    interpolate_curvature_after_goal: bool = False
    use_cancel_deceleration: bool = False
    cancel_deceleration: float = Field(3.2, gt=0.0)
    use_interpolation: bool = True
    stateful: bool = True
    # navstack additions (module docstring)
    controller_frequency: float = Field(20.0, gt=0.0)
    xy_goal_tolerance: float = Field(0.25, ge=0.0)
    min_turning_radius: float = Field(0.0, ge=0.0)
    back_out_speed: float = Field(0.0, ge=0.0)
    back_out_max_distance: float = Field(0.3, gt=0.0)

    @model_validator(mode="after")
    def _check(self) -> Self:
        if self.use_rotate_to_heading and self.allow_reversing:
            raise _CrossFieldError(
                "use_rotate_to_heading and allow_reversing cannot both be true: a robot that "
                "reverses along the path must not turn in place to face it",
                key_path="allow_reversing",
                suggestion="set use_rotate_to_heading: false to drive in reverse, or "
                           "allow_reversing: false")
        if self.min_turning_radius > 0.0 and self.use_rotate_to_heading:
            raise _CrossFieldError(
                f"min_turning_radius {self.min_turning_radius} m describes a car-like robot, "
                f"which cannot rotate in place, but use_rotate_to_heading is true",
                key_path="use_rotate_to_heading",
                suggestion="set use_rotate_to_heading: false for car-like robots")
        if self.interpolate_curvature_after_goal and not self.use_fixed_curvature_lookahead:
            raise _CrossFieldError(
                "interpolate_curvature_after_goal needs use_fixed_curvature_lookahead: true",
                key_path="interpolate_curvature_after_goal",
                suggestion="set use_fixed_curvature_lookahead: true or disable "
                           "interpolate_curvature_after_goal")
        if self.min_lookahead_dist > self.max_lookahead_dist:
            raise _CrossFieldError(
                f"min_lookahead_dist ({self.min_lookahead_dist}) exceeds max_lookahead_dist "
                f"({self.max_lookahead_dist})", key_path="min_lookahead_dist")
        if self.use_cost_regulated_linear_velocity_scaling and \
                self.inflation_cost_scaling_factor <= 0.0:
            raise _CrossFieldError(
                f"inflation_cost_scaling_factor must be > 0 for cost regulated scaling, got "
                f"{self.inflation_cost_scaling_factor}", key_path="inflation_cost_scaling_factor",
                suggestion="use the inflation layer's cost_scaling_factor, or set "
                           "use_cost_regulated_linear_velocity_scaling: false")
        return self

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Validate a Nav2-layout mapping; every error names ``file`` and the key path."""
        try:
            return super().from_mapping(data, file=file, key_path=key_path)
        except _CrossFieldError as exc:
            path = f"{key_path}.{exc.key_path}" if key_path else exc.key_path
            raise ConfigError(exc.reason, file=file, key_path=path,
                              suggestion=exc.suggestion) from None

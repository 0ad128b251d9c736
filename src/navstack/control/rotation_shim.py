"""Rotation shim controller (Nav2 ``nav2_rotation_shim_controller``).

Wraps a primary controller (``primary_controller``: any controller plugin; its parameters
sit in the same section, as in Nav2).  When a new path arrives, the point of the path
``forward_sampling_distance`` ahead of the robot along it is taken in the robot frame;
if its bearing exceeds ``angular_dist_threshold`` the robot rotates in place toward it at
``rotate_to_heading_angular_vel`` (limited to ``max_angular_accel`` from the current yaw
rate per control period), checking the rotation ``simulate_ahead_time`` ahead against
the costmap; once the bearing is within the threshold the primary controller takes over
until the next new path.  ``rotate_to_goal_heading``: within ``goal_tolerance`` of the
path's end (navstack; Nav2 asks the goal checker) the shim turns to the goal's heading
itself.  ``rotate_to_heading_once`` (Nav2 Iron+): a replanned path to the same goal does
not trigger the shim again.

navstack departure: the rotation slows down to stop at the heading (the deceleration of
``max_angular_accel``, as RPP's rotate-to-heading does) instead of keeping
``rotate_to_heading_angular_vel`` until the threshold is crossed; with a base that cannot
brake instantly Nav2's rule overshoots and hands the primary controller a heading error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Self

import numpy as np
from pydantic import Field

from navstack.core.errors import ConfigError, NoValidControl
from navstack.core.geometry import angle_diff
from navstack.core.interfaces import Controller
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.params import Params
from navstack.core.plugins import CONTROLLERS, register_controller
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION
from navstack.costmap.footprint import footprint_cost, footprint_costs

if TYPE_CHECKING:
    from navstack.costmap.costmap_2d import Costmap2D

__all__ = ["RotationShimController", "RotationShimParams"]

_OWN = {"primary_controller", "angular_dist_threshold", "forward_sampling_distance",
        "rotate_to_heading_angular_vel", "max_angular_accel", "simulate_ahead_time",
        "rotate_to_goal_heading", "rotate_to_heading_once", "closed_loop",
        "controller_frequency", "goal_tolerance", "allow_unknown", "plugin"}


class RotationShimParams(Params):
    """Nav2 rotation shim parameters (names and defaults); ``primary`` holds the primary
    controller's validated parameters (the other keys of the section)."""

    primary_controller: str
    angular_dist_threshold: float = Field(0.785, gt=0.0, le=math.pi)
    forward_sampling_distance: float = Field(0.5, gt=0.0)
    rotate_to_heading_angular_vel: float = Field(1.8, gt=0.0)
    max_angular_accel: float = Field(3.2, gt=0.0)
    simulate_ahead_time: float = Field(1.0, ge=0.0)
    rotate_to_goal_heading: bool = False
    rotate_to_heading_once: bool = False
    closed_loop: bool = True
    controller_frequency: float = Field(20.0, gt=0.0)
    """The server's rate: the control period that limits the yaw acceleration."""
    allow_unknown: bool = True
    """navstack: a rotation through unknown cells is allowed (Nav2 refuses it when the
    costmap tracks unknown space)."""
    goal_tolerance: float = Field(0.25, ge=0.0)
    """[m] navstack: distance to the path's end within which ``rotate_to_goal_heading``
    applies (Nav2 asks the goal checker)."""
    primary: Any = None

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """The shim's own keys validated here, the rest by the primary controller's
        params model -- errors name the file and the key in either."""
        raw = dict(data or {})
        own = {k: v for k, v in raw.items() if k in _OWN and k != "plugin"}
        rest = {k: v for k, v in raw.items() if k not in _OWN}
        name = own.get("primary_controller")
        if not isinstance(name, str) or not name:
            raise ConfigError("required key is missing", file=file,
                              key_path=f"{key_path}.primary_controller".lstrip("."),
                              suggestion="name the wrapped controller, e.g. "
                                         "'dwb_core::DWBLocalPlanner'")
        try:
            primary_cls = CONTROLLERS.get(name)
        except Exception as exc:
            raise ConfigError(f"unknown controller plugin '{name}': {exc}", file=file,
                              key_path=f"{key_path}.primary_controller".lstrip(".")) from None
        if primary_cls is RotationShimController:
            raise ConfigError("the rotation shim cannot wrap itself", file=file,
                              key_path=f"{key_path}.primary_controller".lstrip("."))
        fields = getattr(primary_cls.params_model, "model_fields", {})
        rest.update({k: v for k, v in own.items() if k in fields})  # shared (frequency)
        primary = primary_cls.params_model.from_mapping(rest, file=file, key_path=key_path)
        out = super().from_mapping(own, file=file, key_path=key_path)
        return out.model_copy(update={"primary": (primary_cls, primary)})


@register_controller("RotationShimController",
                     nav2="nav2_rotation_shim_controller::RotationShimController")
class RotationShimController(Controller):
    """Rotate in place toward the path, then hand over to the primary controller."""

    params_model = RotationShimParams
    params: RotationShimParams

    def __init__(self, params: RotationShimParams | None = None, *,
                 footprint: Footprint | None = None) -> None:
        if params is None:
            raise ConfigError("RotationShimController needs params with a primary_controller")
        super().__init__(params, footprint=footprint)
        cls, primary_params = params.primary
        self.primary: Controller = cls(primary_params, footprint=footprint)
        self._path: Path | None = None
        self._goal_xy: tuple[float, float] | None = None
        self.path_updated = False
        self.rotating = False
        self.last_wz = 0.0
        self.rotations = 0
        """Control cycles in which the shim rotated instead of the primary controller."""

    # --- nav2_core::Controller ----------------------------------------------------------------
    def set_plan(self, path: Path) -> None:
        goal = tuple(path.as_array()[-1, :2]) if path.num_poses else None
        changed = goal is None or self._goal_xy is None or math.dist(goal, self._goal_xy) > 1e-6
        self.path_updated = changed if self.params.rotate_to_heading_once else True
        self._goal_xy = goal
        self._path = path
        self.primary.set_plan(path)

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        self.primary.set_speed_limit(limit, percentage)

    def reset(self) -> None:
        self._path, self._goal_xy = None, None
        self.path_updated = self.rotating = False
        self.last_wz = 0.0
        self.primary.reset()

    def compute(self, pose: Pose2D, velocity: Twist2D, path: Path | None,
                costmap: Costmap2D, now: float = 0.0) -> Twist2D:
        if path is not None and path is not self._path:
            self.set_plan(path)
        plan = self._path
        if plan is None or not plan.num_poses:
            return self._primary(pose, velocity, path, costmap, now)
        p = self.params
        xy = plan.as_array()
        if p.rotate_to_goal_heading and math.hypot(xy[-1, 0] - pose.x,
                                                   xy[-1, 1] - pose.y) <= p.goal_tolerance:
            err = angle_diff(float(xy[-1, 2]), pose.theta)
            return self._rotate(err, pose, velocity, costmap)
        if self.path_updated:
            target = self._sampled_point(xy, pose)
            bearing = angle_diff(math.atan2(target[1] - pose.y, target[0] - pose.x),
                                 pose.theta)
            # near the end of the path the bearing to its last point is meaningless (the
            # robot may stand on it): the primary controller (and its goal logic) drives
            far = math.hypot(target[0] - pose.x, target[1] - pose.y) >= p.forward_sampling_distance
            if far and abs(bearing) > p.angular_dist_threshold:
                self.rotating = True
                return self._rotate(bearing, pose, velocity, costmap)
        self.path_updated = self.rotating = False
        return self._primary(pose, velocity, path, costmap, now)

    # --- internals --------------------------------------------------------------------------
    def _primary(self, pose: Pose2D, velocity: Twist2D, path: Path | None,
                 costmap: Costmap2D, now: float) -> Twist2D:
        cmd = self.primary.compute(pose, velocity, path, costmap, now)
        self.last_wz = cmd.wz
        return cmd

    def _sampled_point(self, xy: np.ndarray, pose: Pose2D) -> tuple[float, float]:
        """The first path point ``forward_sampling_distance`` beyond the path point
        nearest the robot, or the path's end if it is shorter (Nav2 Jazzy).  Nav2
        measures from the path's first pose, which is the robot's position when the plan
        is new; the controller server also hands over the same plan re-transformed into
        ``odom`` (a new object) after the robot has moved along it."""
        k = int(np.argmin(np.hypot(xy[:, 0] - pose.x, xy[:, 1] - pose.y)))
        d = np.hypot(xy[k:, 0] - xy[k, 0], xy[k:, 1] - xy[k, 1])
        far = np.nonzero(d >= self.params.forward_sampling_distance)[0]
        i = k + int(far[0]) if len(far) else len(xy) - 1
        return float(xy[i, 0]), float(xy[i, 1])

    def _rotate(self, error: float, pose: Pose2D, velocity: Twist2D,
                costmap: Costmap2D) -> Twist2D:
        p = self.params
        dt = 1.0 / p.controller_frequency
        current = velocity.wz if p.closed_loop else self.last_wz
        sign = 1.0 if error > 0.0 else -1.0
        # slow down so as to stop at the heading: w^2 = 2 a |error|
        stop_speed = math.sqrt(2.0 * p.max_angular_accel * abs(error))
        wz = sign * min(p.rotate_to_heading_angular_vel, stop_speed)
        wz = min(max(wz, current - p.max_angular_accel * dt), current + p.max_angular_accel * dt)
        self._check_rotation(wz, error, pose, costmap)
        self.rotations += 1
        self.last_wz = wz
        return Twist2D(0.0, 0.0, wz)

    def _check_rotation(self, wz: float, error: float, pose: Pose2D,
                        costmap: Costmap2D) -> None:
        """Nav2 ``isCollisionFree``: no lethal cell under the footprint along the
        rotation, for ``simulate_ahead_time`` or until the heading is reached.  A round
        robot (footprint from ``robot_radius``) covers the same disc at every heading, so
        turning in place cannot hit anything; its polygon approximation would otherwise
        refuse a turn when a rotated vertex grazes a lethal cell the disc already touches
        (Nav2 checks a round robot by the cost at its centre, which a turn leaves as is)."""
        if (self.footprint is None or self.footprint.radius is not None
                or self.params.simulate_ahead_time <= 0.0 or wz == 0.0):
            return
        turn = min(abs(wz) * self.params.simulate_ahead_time, abs(error))
        steps = max(1, math.ceil(turn / 0.05))
        th = pose.theta + math.copysign(1.0, wz) * np.linspace(turn / steps, turn, steps)
        poses = np.column_stack((np.full(steps, pose.x), np.full(steps, pose.y), th))
        cost = footprint_costs(costmap, poses, self.footprint.polygon)
        unknown = (cost == NO_INFORMATION) & (not self.params.allow_unknown)
        if np.any((cost == LETHAL_OBSTACLE) | unknown) and not self._starts_lethal(pose, costmap):
            raise NoValidControl("RotationShimController detected a potential collision "
                                 "ahead while rotating toward the path")

    def _starts_lethal(self, pose: Pose2D, costmap: Costmap2D) -> bool:
        """True when the footprint already covers a lethal cell where it stands: turning
        in place does not make that worse (a round robot's footprint does not change),
        so it is allowed (Nav2 refuses it and the robot waits for a recovery)."""
        assert self.footprint is not None
        c = footprint_cost(costmap, (pose.x, pose.y, pose.theta), self.footprint.polygon)
        return c == LETHAL_OBSTACLE

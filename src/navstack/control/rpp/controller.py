"""Regulated Pure Pursuit controller (Nav2 ``RegulatedPurePursuitController``).

Each :meth:`RegulatedPurePursuitController.compute` cycle, as Nav2's
``computeVelocityCommands``:

1. prune the plan and bring the part near the robot into the robot frame
   (:mod:`~navstack.control.rpp.path_handler`);
2. lookahead distance: ``lookahead_dist``, or ``|v| * lookahead_time`` clamped to
   ``[min_lookahead_dist, max_lookahead_dist]`` with ``use_velocity_scaled_lookahead_dist``;
   with ``allow_reversing`` it never reaches past the next cusp;
3. carrot on the path at that distance; curvature ``2 y / d^2`` of the arc through it
   (or through a second carrot at ``curvature_lookahead_dist`` with
   ``use_fixed_curvature_lookahead``); with ``allow_reversing`` the robot drives backward
   when the carrot is behind it;
4. rotate in place to the goal heading once within ``xy_goal_tolerance`` of the path end,
   or toward the carrot when it is more than ``rotate_to_heading_min_angle`` off
   (``use_rotate_to_heading``), limited by ``max_angular_accel`` and slowing so as not
   to overshoot;
5. otherwise ``desired_linear_vel`` regulated by curvature and by the robot cell's cost
   (the smaller), floored at ``regulated_linear_scaling_min_speed``, slowed on approach to
   the goal, and ``w = v * curvature`` (clamped to ``1 / min_turning_radius`` for
   car-like robots; navstack addition);
6. with ``use_collision_detection``, project ``(v, w)`` forward and raise
   :class:`~navstack.control.rpp.errors.CollisionAhead` (a ``NoValidControl``) naming the
   pose, the time and the cost when it would hit a lethal cell
   (:mod:`~navstack.control.rpp.collision`).  A turn in place (step 4) is judged instead
   by the whole angle it must sweep -- to within ``rotate_to_heading_min_angle`` of the
   carrot, or to the goal heading -- and turns the other way round when only that way
   is free (navstack addition; Nav2 projects ``(0, w)`` for
   ``max_allowed_time_to_collision_up_to_carrot`` and always turns the shorter way).  A
   turn blocked both ways raises at once, on every cycle, so the controller server fails
   the goal after ``failure_tolerance`` and the navigator's recovery backs the robot
   away; the time-based projection flickered as ``w`` followed the odometry, and a
   TurtleBot pinned beside a wall crept round at 0.01 rad/s for 15 s before anything
   gave up (docs/decisions.md, "In-place turns judged by their sweep").  With
   ``back_out_speed`` > 0 a turn toward the path blocked both ways first backs straight
   out (reverse projection free, at most ``back_out_max_distance``) until one way is free.

Pose, velocity and plan are in the costmap frame (the controller server transforms).  A
plan handed over again, e.g. re-transformed after TF moved, restarts pruning with a search
of the whole plan for the closest pose; later cycles search forward from there within
``max_robot_pose_search_dist`` as Nav2 does.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.control.rpp.collision import CollisionHit, RPPCollisionChecker
from navstack.control.rpp.errors import CollisionAhead, CostmapTooSmall
from navstack.control.rpp.params import RegulatedPurePursuitParams
from navstack.control.rpp.path_handler import PathHandler
from navstack.control.rpp.regulation import (
    approach_velocity_constraint,
    calculate_curvature,
    cost_constraint,
    curvature_constraint,
    find_velocity_sign_change,
    get_lookahead_point,
)
from navstack.core.errors import InvalidMessage, InvalidPath
from navstack.core.geometry import normalize_angle
from navstack.core.interfaces import Controller
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.plugins import register_controller
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D

FloatArray = NDArray[np.float64]


@register_controller(
    "RegulatedPurePursuit",
    nav2="nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController")
class RegulatedPurePursuitController(Controller):
    """``compute(pose, velocity, path, costmap, now) -> Twist2D`` (module docstring).

    ``footprint`` is used for collision checks and its inscribed radius for the cost
    regulation; without one the robot is a point (inscribed radius 0: the distance to
    obstacles is underestimated, so the robot slows earlier).
    """

    params_model = RegulatedPurePursuitParams
    params: RegulatedPurePursuitParams

    def __init__(self, params: RegulatedPurePursuitParams | Mapping[str, Any] | None = None,
                 *, footprint: Footprint | None = None) -> None:
        super().__init__(params if isinstance(params, RegulatedPurePursuitParams)
                         else RegulatedPurePursuitParams.from_mapping(params),
                         footprint=footprint)
        self.collision_checker = RPPCollisionChecker(footprint)
        self.path_handler = PathHandler()
        self._desired_linear_vel = self.params.desired_linear_vel
        self._fresh_plan = True
        self._has_reached_xy_tolerance = False
        self._cancelling = False
        self._finished_cancelling = False
        self.is_rotating_to_heading = False
        """Whether the last command was a rotation in place."""
        self.is_backing_out = False
        """Whether the last command backed out of a turn blocked both ways
        (``back_out_speed``)."""
        self._back_out_from: tuple[float, float] | None = None
        self.turn_sign = 0.0
        """Direction of the current turn in place (+1 counter-clockwise, -1 clockwise; 0
        when not turning): kept while that way stays free, so a turn started the long way
        round does not switch back."""
        self.last_carrot: tuple[float, float] | None = None
        """Carrot of the last cycle in the costmap frame (Nav2 ``lookahead_point``)."""
        self.last_curvature = 0.0
        """Curvature [1/m] used for regulation in the last cycle."""
        self.last_lookahead_dist = 0.0

    # --- plan and limits -------------------------------------------------------------------
    def set_plan(self, path: Path) -> None:
        """Take a new plan (Nav2 ``setPlan``): pruning restarts, the goal latch clears."""
        self.path_handler.set_plan(path)
        self._fresh_plan = True
        self._has_reached_xy_tolerance = False

    def _accept_plan(self, path: Path | None, costmap: Costmap2D) -> None:
        current = self.path_handler.path
        if path is not None and path is not current:
            arr = path.as_array()
            if current is None or arr.shape != current.as_array().shape or not np.array_equal(
                    arr, current.as_array()):
                self.set_plan(path)
            else:
                self.path_handler.path = path
        if self.path_handler.path is None:
            raise InvalidPath("no plan: pass a path to compute() or call set_plan() first")
        frame = self.path_handler.path.header.frame_id
        if frame and costmap.frame_id and frame != costmap.frame_id:
            raise InvalidPath(
                f"plan is in frame '{frame}' but the costmap is in '{costmap.frame_id}'; "
                f"transform the plan (and pose) into '{costmap.frame_id}' before compute()")

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2 speed limit: 0 restores ``desired_linear_vel``; else ``limit`` percent of it
        (``percentage``) or ``limit`` m/s."""
        base = self.params.desired_linear_vel
        if limit == 0.0:
            self._desired_linear_vel = base
        elif percentage:
            self._desired_linear_vel = base * limit / 100.0
        else:
            self._desired_linear_vel = limit

    def reset(self) -> None:
        """Clear the cancel state and the goal-heading latch (Nav2 ``reset``)."""
        self._cancelling = False
        self._finished_cancelling = False
        self._has_reached_xy_tolerance = False
        self.turn_sign = 0.0
        self._back_out_from = None

    def cancel(self) -> bool:
        """Request a stop; True once stopped (immediately without
        ``use_cancel_deceleration``, else when decelerated to zero by ``compute``)."""
        if not self.params.use_cancel_deceleration:
            return True
        self._cancelling = True
        return self._finished_cancelling

    # --- pieces of the control law ---------------------------------------------------------
    def lookahead_distance(self, velocity: Twist2D) -> float:
        """Nav2 ``getLookAheadDistance``."""
        p = self.params
        if not p.use_velocity_scaled_lookahead_dist:
            return p.lookahead_dist
        return min(max(abs(velocity.vx) * p.lookahead_time, p.min_lookahead_dist),
                   p.max_lookahead_dist)

    def _rotate_to_heading(self, angle: float, velocity: Twist2D) -> tuple[float, float]:
        """In-place rotation toward ``angle`` [rad] (Nav2 ``rotateToHeading``)."""
        p = self.params
        dt = 1.0 / p.controller_frequency
        sign = 1.0 if angle > 0.0 else -1.0
        w = sign * p.rotate_to_heading_angular_vel
        w = min(max(w, velocity.wz - p.max_angular_accel * dt),
                velocity.wz + p.max_angular_accel * dt)
        max_vel_to_stop = math.sqrt(2.0 * p.max_angular_accel * abs(angle))
        if abs(w) > max_vel_to_stop:
            w = sign * max_vel_to_stop
        return 0.0, w

    def _turn_in_place(self, angle: float, margin: float, velocity: Twist2D, pose: Pose2D,
                       costmap: Costmap2D, toward: str) -> tuple[float, float]:
        """Rotate to heading (:meth:`_rotate_to_heading`) the way whose sweep is free.

        ``angle`` [rad] is the heading error, ``margin`` [rad] how close to it the turn
        ends (``rotate_to_heading_min_angle`` toward the carrot, 0 to the goal heading).
        Without collision detection: the shorter way, as Nav2.  Otherwise the shorter way
        unless its sweep reaches lethal cost and the other way's does not (the direction
        of the turn under way is tried first); both blocked raises ``CollisionAhead``
        (module docstring, step 6)."""
        p = self.params
        if not p.use_collision_detection:
            return self._rotate_to_heading(angle, velocity)
        short = 1.0 if angle > 0.0 else -1.0
        turn = {short: abs(angle), -short: 2.0 * math.pi - abs(angle)}
        order = (-short, short) if self.turn_sign == -short else (short, -short)
        hits: dict[float, tuple[float, CollisionHit]] = {}
        for sign in order:
            found = self.collision_checker.first_collision_turning(
                costmap, pose, sign * max(turn[sign] - margin, 0.0))
            if found is None:
                self.turn_sign = sign
                return self._rotate_to_heading(sign * turn[sign], velocity)
            hits[sign] = found
        self.turn_sign = 0.0
        body = "footprint" if self.footprint is not None else "centre"
        turned, hit = hits[short]
        x, y, _ = hit.pose
        if turned != 0.0 and toward == "path" and p.back_out_speed > 0.0:
            backing = self._back_out(pose, costmap)
            if backing is not None:
                return backing
        if turned == 0.0:
            raise CollisionAhead(
                f"RegulatedPurePursuitController detected collision ahead: the robot {body} "
                f"at ({x:.2f}, {y:.2f}) is already in lethal cost {hit.cost}; clear the "
                f"costmap or back out with a recovery", hit.pose, 0.0, hit.cost)
        other, _ = hits[-short]
        raise CollisionAhead(
            f"RegulatedPurePursuitController detected collision ahead: turning in place "
            f"toward the {toward} is blocked both ways: the robot {body} at ({x:.2f}, {y:.2f}) "
            f"would reach lethal cost {hit.cost} after turning {abs(turned):.2f} of "
            f"{max(turn[short] - margin, 0.0):.2f} rad the shorter way and after "
            f"{abs(other):.2f} of {max(turn[-short] - margin, 0.0):.2f} rad the other way"
            + (f", and backing out is blocked or already {p.back_out_max_distance:.2f} m long"
               if p.back_out_speed > 0.0 and toward == "path" else "")
            + "; back away from the obstacle",
            hit.pose, abs(turned) / p.rotate_to_heading_angular_vel, hit.cost)

    def _back_out(self, pose: Pose2D, costmap: Costmap2D) -> tuple[float, float] | None:
        """``(-back_out_speed, 0)`` while the reverse projection (for
        ``max_allowed_time_to_collision_up_to_carrot``) is free and this turn has backed
        out less than ``back_out_max_distance``; else None."""
        p = self.params
        if self._back_out_from is None:
            self._back_out_from = (pose.x, pose.y)
        x0, y0 = self._back_out_from
        if math.hypot(pose.x - x0, pose.y - y0) >= p.back_out_max_distance:
            return None
        if self.collision_checker.first_collision(
                costmap, pose, -p.back_out_speed, 0.0, math.inf,
                p.max_allowed_time_to_collision_up_to_carrot) is not None:
            return None
        self.is_backing_out = True
        return -p.back_out_speed, 0.0

    def _cost_at_robot(self, pose: Pose2D, costmap: Costmap2D) -> float:
        cost = self.collision_checker.cost_at(costmap, pose.x, pose.y)
        if cost is None:
            raise CostmapTooSmall(
                f"RegulatedPurePursuitController: the robot at ({pose.x:.2f}, {pose.y:.2f}) is "
                f"outside the costmap in frame '{costmap.frame_id}'; the costmap must contain "
                f"the robot (use a rolling window or a larger costmap)")
        return float(cost)

    def apply_constraints(self, curvature: float, pose_cost: float, plan: FloatArray,
                          sign: float) -> float:
        """Regulated linear velocity (Nav2 ``applyConstraints``), signed."""
        p = self.params
        v = self._desired_linear_vel
        curvature_vel = cost_vel = v
        if p.use_regulated_linear_velocity_scaling:
            curvature_vel = curvature_constraint(v, curvature,
                                                 p.regulated_linear_scaling_min_radius)
        if p.use_cost_regulated_linear_velocity_scaling:
            inscribed = self.footprint.inscribed_radius if self.footprint is not None else 0.0
            cost_vel = cost_constraint(v, pose_cost, inscribed, p.cost_scaling_dist,
                                       p.cost_scaling_gain, p.inflation_cost_scaling_factor)
        v = max(min(cost_vel, curvature_vel), p.regulated_linear_scaling_min_speed)
        v = approach_velocity_constraint(v, plan, p.min_approach_linear_velocity,
                                         p.approach_velocity_scaling_dist)
        return sign * min(max(abs(v), 0.0), self._desired_linear_vel)

    # --- the cycle -------------------------------------------------------------------------
    def compute(self, pose: Pose2D, velocity: Twist2D, path: Path | None, costmap: Costmap2D,
                now: float = 0.0) -> Twist2D:
        """Velocity command for this cycle; raises ``CollisionAhead``/``CostmapTooSmall``
        (``NoValidControl``) or ``InvalidPath``.  A ``path`` different from the current one
        acts as :meth:`set_plan`; ``None`` keeps it."""
        for value, what in ((pose.x, "pose.x"), (pose.y, "pose.y"), (pose.theta, "pose.theta")):
            if not math.isfinite(value):
                raise InvalidMessage(f"RPP compute: {what} is {value}; pose must be finite")
        if not velocity.is_finite():
            raise InvalidMessage(f"RPP compute: velocity {velocity} is not finite")
        p = self.params
        self._accept_plan(path, costmap)
        search = p.max_robot_pose_search_dist
        if search is None:
            search = costmap.size_x_m / 2.0
        if search < 0.0 or self._fresh_plan:
            search = math.inf
        plan, _ = self.path_handler.transform_global_plan(
            pose, costmap, search, p.interpolate_curvature_after_goal)
        self._fresh_plan = False

        lookahead = self.lookahead_distance(velocity)
        curv_lookahead = p.curvature_lookahead_dist
        if p.allow_reversing:
            dist_to_cusp = find_velocity_sign_change(plan)
            lookahead = min(lookahead, dist_to_cusp)
            curv_lookahead = min(curv_lookahead, dist_to_cusp)
        self.last_lookahead_dist = lookahead
        carrot = get_lookahead_point(lookahead, plan, use_interpolation=p.use_interpolation)
        heading_carrot = carrot
        curvature = calculate_curvature(*carrot)
        if p.use_fixed_curvature_lookahead:
            heading_carrot = get_lookahead_point(curv_lookahead, plan,
                                                 p.interpolate_curvature_after_goal,
                                                 p.use_interpolation)
            curvature = calculate_curvature(*heading_carrot)
        sign = (1.0 if carrot[0] >= 0.0 else -1.0) if p.allow_reversing else 1.0

        angle_to_path = math.atan2(heading_carrot[1], heading_carrot[0])
        if sign < 0.0:
            angle_to_path = normalize_angle(angle_to_path + math.pi)
        self.is_backing_out = False
        if self._should_rotate_to_goal(carrot):
            self.is_rotating_to_heading = True
            v, w = self._turn_in_place(float(plan[-1, 2]), 0.0, velocity, pose, costmap,
                                       "goal heading")
        elif p.use_rotate_to_heading and abs(angle_to_path) > p.rotate_to_heading_min_angle:
            self.is_rotating_to_heading = True
            v, w = self._turn_in_place(angle_to_path, p.rotate_to_heading_min_angle, velocity,
                                       pose, costmap, "path")
        else:
            self.is_rotating_to_heading = False
            self.turn_sign = 0.0
            self._back_out_from = None
            v = self.apply_constraints(curvature, self._cost_at_robot(pose, costmap), plan, sign)
            if self._cancelling:
                v = velocity.vx - sign * p.cancel_deceleration / p.controller_frequency
                if (sign > 0.0 and v <= 0.0) or (sign < 0.0 and v >= 0.0):
                    v = 0.0
                    self._finished_cancelling = True
            k = curvature
            if p.min_turning_radius > 0.0:
                k_max = 1.0 / p.min_turning_radius
                k = min(max(k, -k_max), k_max)
            w = v * k
        self.last_curvature = curvature
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        self.last_carrot = (pose.x + c * carrot[0] - s * carrot[1],
                            pose.y + s * carrot[0] + c * carrot[1])

        if p.use_collision_detection and not self.is_rotating_to_heading:
            self._check_collision(pose, v, w, math.hypot(*carrot), costmap)
        return Twist2D(v, 0.0, w)

    def _should_rotate_to_goal(self, carrot: tuple[float, float]) -> bool:
        """Nav2 ``shouldRotateToGoalHeading``: the carrot (then the path end) is within
        ``xy_goal_tolerance``; latched with ``stateful``."""
        p = self.params
        if not p.use_rotate_to_heading:
            return False
        near = math.hypot(*carrot) < p.xy_goal_tolerance
        if p.stateful:
            self._has_reached_xy_tolerance = self._has_reached_xy_tolerance or near
            return self._has_reached_xy_tolerance
        return near

    def _check_collision(self, pose: Pose2D, v: float, w: float, carrot_dist: float,
                         costmap: Costmap2D) -> None:
        p = self.params
        hit = self.collision_checker.first_collision(
            costmap, pose, v, w, carrot_dist, p.max_allowed_time_to_collision_up_to_carrot)
        if hit is None:
            return
        x, y, _ = hit.pose
        body = "footprint" if self.footprint is not None else "centre"
        if hit.time == 0.0:
            msg = (f"RegulatedPurePursuitController detected collision ahead: the robot "
                   f"{body} at ({x:.2f}, {y:.2f}) is already in lethal cost {hit.cost}; "
                   f"clear the costmap or back out with a recovery")
        else:
            msg = (f"RegulatedPurePursuitController detected collision ahead: the robot "
                   f"{body} would reach lethal cost {hit.cost} at ({x:.2f}, {y:.2f}) in "
                   f"{hit.time:.2f} s on the commanded arc (v {v:.2f} m/s, w {w:.2f} rad/s); "
                   f"replan around the obstacle")
        raise CollisionAhead(msg, hit.pose, hit.time, hit.cost)

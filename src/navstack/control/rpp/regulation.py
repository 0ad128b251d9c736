"""Regulated Pure Pursuit geometry and regulation heuristics (Nav2 formulas).

Pure functions on a plan already expressed in the robot frame (``(M, 3)`` x forward,
y left, theta), as Nav2 computes them after ``transformGlobalPlan``:

* :func:`calculate_curvature`: pure pursuit curvature ``2 y / (x^2 + y^2)`` of the arc
  through the robot and the carrot (0 when the carrot is within ~3 cm);
* :func:`get_lookahead_point`: the first pose at least the lookahead distance away,
  interpolated onto the lookahead circle (``circleSegmentIntersection``), or the last pose
  (projected beyond the goal with ``interpolate_after_goal``);
* :func:`find_velocity_sign_change`: distance to the first cusp of the plan;
* ``heuristics``: :func:`curvature_constraint`, :func:`cost_constraint`,
  :func:`approach_velocity_scaling_factor` and :func:`approach_velocity_constraint`,
  exactly Nav2's ``regulation_functions.hpp`` (Macenski et al., "Regulated Pure Pursuit for
  Robot Path Tracking", Autonomous Robots 2023).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import FREE_SPACE, NO_INFORMATION

FloatArray = NDArray[np.float64]


def calculate_curvature(x: float, y: float) -> float:
    """Curvature [1/m] of the arc from the robot (origin, facing +x) through ``(x, y)``."""
    d2 = x * x + y * y
    return 2.0 * y / d2 if d2 > 0.001 else 0.0


def circle_segment_intersection(p1: tuple[float, float], p2: tuple[float, float],
                                r: float) -> tuple[float, float]:
    """Point of segment ``p1 -> p2`` on the circle of radius ``r`` about the origin.

    ``p1`` inside and ``p2`` outside the circle (or the other way round): the sign of
    ``|p2| - |p1|`` picks the root on the segment (Nav2 ``circleSegmentIntersection``).
    """
    x1, y1 = p1
    x2, y2 = p2
    dx, dy = x2 - x1, y2 - y1
    dr2 = dx * dx + dy * dy
    cross = x1 * y2 - x2 * y1
    dd = (x2 * x2 + y2 * y2) - (x1 * x1 + y1 * y1)
    root = math.sqrt(max(0.0, r * r * dr2 - cross * cross))
    sign = math.copysign(1.0, dd)
    return ((cross * dy + sign * dx * root) / dr2, (-cross * dx + sign * dy * root) / dr2)


def get_lookahead_point(lookahead_dist: float, plan: FloatArray,
                        interpolate_after_goal: bool = False,
                        use_interpolation: bool = True) -> tuple[float, float]:
    """Carrot ``(x, y)`` in the robot frame at ``lookahead_dist`` along a robot-frame plan."""
    dist = np.hypot(plan[:, 0], plan[:, 1])
    beyond = np.nonzero(dist >= lookahead_dist)[0]
    if len(beyond) == 0:
        last = plan[-1]
        if interpolate_after_goal and len(plan) > 1:
            prev = plan[-2]
            heading = math.atan2(last[1] - prev[1], last[0] - prev[0])
            projected = (last[0] + math.cos(heading) * lookahead_dist,
                         last[1] + math.sin(heading) * lookahead_dist)
            return circle_segment_intersection((float(last[0]), float(last[1])), projected,
                                               lookahead_dist)
        return float(last[0]), float(last[1])
    i = int(beyond[0])
    if i > 0 and use_interpolation:
        return circle_segment_intersection((float(plan[i - 1, 0]), float(plan[i - 1, 1])),
                                           (float(plan[i, 0]), float(plan[i, 1])),
                                           lookahead_dist)
    return float(plan[i, 0]), float(plan[i, 1])


def find_velocity_sign_change(plan: FloatArray) -> float:
    """Distance from the robot to the first cusp of a robot-frame plan (``inf`` if none).

    A cusp is a pose where the displacement reverses (negative dot product of the
    displacements in and out), or where two poses overlap with different headings
    (rotation in place), as Nav2's ``findVelocitySignChange``.
    """
    if len(plan) < 3:
        return math.inf
    d = np.diff(plan[:, :2], axis=0)
    oa, ab = d[:-1], d[1:]
    cusp = (oa[:, 0] * ab[:, 0] + oa[:, 1] * ab[:, 1]) < 0.0
    th = plan[:, 2]
    turn_in = (np.hypot(oa[:, 0], oa[:, 1]) == 0.0) & (th[:-2] != th[1:-1])
    turn_out = (np.hypot(ab[:, 0], ab[:, 1]) == 0.0) & (th[1:-1] != th[2:])
    hits = np.nonzero(cusp | turn_in | turn_out)[0]
    if len(hits) == 0:
        return math.inf
    p = plan[int(hits[0]) + 1]
    return float(math.hypot(p[0], p[1]))


def path_length(plan: FloatArray) -> float:
    """Integrated length of a plan [m] (Nav2 ``calculate_path_length``)."""
    if len(plan) < 2:
        return 0.0
    return float(np.sum(np.hypot(*np.diff(plan[:, :2], axis=0).T)))


# --- heuristics (nav2_regulated_pure_pursuit_controller/regulation_functions.hpp) ---------
def curvature_constraint(raw_linear_vel: float, curvature: float, min_radius: float) -> float:
    """Slow down on tight turns: ``v (1 - |r - r_min| / r_min)`` below ``r_min``."""
    radius = abs(1.0 / curvature) if curvature != 0.0 else math.inf
    if radius < min_radius:
        return raw_linear_vel * (1.0 - abs(radius - min_radius) / min_radius)
    return raw_linear_vel


def distance_from_cost(pose_cost: float, inscribed_radius: float,
                       inflation_cost_scaling_factor: float) -> float:
    """Distance to the nearest obstacle implied by an inflation cost (Nav2's inverse of the
    inflation function, with 253 as in Nav2): ``(k r - ln c + ln 253) / k``."""
    k = inflation_cost_scaling_factor
    return (k * inscribed_radius - math.log(pose_cost) + math.log(253.0)) / k


def cost_constraint(raw_linear_vel: float, pose_cost: float, inscribed_radius: float,
                    cost_scaling_dist: float, cost_scaling_gain: float,
                    inflation_cost_scaling_factor: float) -> float:
    """Slow down near obstacles: ``v * gain * d / cost_scaling_dist`` when the distance
    ``d`` implied by the robot cell's cost is below ``cost_scaling_dist`` (free and
    unknown cells do not regulate)."""
    if pose_cost != NO_INFORMATION and pose_cost != FREE_SPACE:
        d = distance_from_cost(pose_cost, inscribed_radius, inflation_cost_scaling_factor)
        if d < cost_scaling_dist:
            return raw_linear_vel * (cost_scaling_gain * d / cost_scaling_dist)
    return raw_linear_vel


def approach_velocity_scaling_factor(plan: FloatArray,
                                     approach_velocity_scaling_dist: float) -> float:
    """``|goal| / approach_velocity_scaling_dist`` once less than that much path remains."""
    if path_length(plan) < approach_velocity_scaling_dist:
        last = plan[-1]
        return float(math.hypot(last[0], last[1])) / approach_velocity_scaling_dist
    return 1.0


def approach_velocity_constraint(constrained_linear_vel: float, plan: FloatArray,
                                 min_approach_velocity: float,
                                 approach_velocity_scaling_dist: float) -> float:
    """Slow down on approach to the goal, never below ``min_approach_velocity``."""
    scaling = approach_velocity_scaling_factor(plan, approach_velocity_scaling_dist)
    approach_vel = max(constrained_linear_vel * scaling, min_approach_velocity)
    return min(constrained_linear_vel, approach_vel)

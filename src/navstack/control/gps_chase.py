"""The planetary rover's GPS goal chase: a PI law on the position error to the goal.

The rover's ``gps_goal_controller`` (``FIELD-ROBOTS.md``) recomputes the goal from the
latest fix, takes the error ``e = goal - position`` (a vector in the odom frame),
integrates it (``I += e dt``) and sends ``x_o = Kp e + Ki I`` ahead of the rover as an
intermediate navigation goal, so the planner and local controller keep it clear of
obstacles.  Written in polar terms this is a heading and a distance PI at once: the
direction of ``x_o`` is the heading command (the integral pulls it towards a target that
a biased or lagging estimate keeps missing on one side) and its length the distance
command.  Anti-windup: the integral is reset whenever the rover is within
``windup_radius`` (2 m) of the goal (the rover's rule) and whenever it points away from the
goal (the rover passed it: an integral built up on the way in would push it on past the
goal), and its contribution is capped at ``max_integral``.
The chase stops when the rover is within ``stop_radius``: the rover's 0.000008 degrees of
latitude, ~0.88 m.  The gains and caps are navstack's (the rover's are not published):
``Kp`` = 1 puts the intermediate goal on the goal itself once it is within ``max_step``;
the integral is kept small (``Ki`` 0.02 /s, at most 2 m): with 0.05 /s, an 8 m cap and no
past-the-goal reset the integral built up on a 20 m approach carried the rover 8 m past
the goal and into a rock (``navstack bench rover``, seed 11).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pydantic import Field

from navstack.core.params import Params

__all__ = ["ChaseStep", "GpsChasePI", "GpsChaseParams"]

#: the rover's stop threshold, 0.000008 degrees, as metres of latitude (1 deg ~ 111.1 km)
ROVER_STOP_DEGREES = 0.000008


class GpsChaseParams(Params):
    """``kp``, ``ki`` [1/s]: gains of ``x_o = kp e + ki I``; ``windup_radius`` [m]: the
    integral is reset within it; ``stop_radius`` [m]: done within it (the rover's ~0.88 m);
    ``max_step`` [m]: longest intermediate goal; ``max_integral`` [m]: cap of the
    integral's contribution ``ki |I|``; ``min_step`` [m]: shortest intermediate goal while
    not yet done (a goal closer than the local controller's tolerance would count as
    reached at once)."""

    kp: float = Field(default=1.0, gt=0.0)
    ki: float = Field(default=0.02, ge=0.0)
    max_integral: float = Field(default=2.0, ge=0.0)
    windup_radius: float = Field(default=2.0, ge=0.0)
    stop_radius: float = Field(default=0.88, gt=0.0)
    max_step: float = Field(default=8.0, gt=0.0)
    min_step: float = Field(default=0.0, ge=0.0)


@dataclass(frozen=True)
class ChaseStep:
    """One PI step: the intermediate goal (``x``, ``y``, ``yaw`` facing the goal) in the
    frame of the inputs, the distance to the goal [m], the integral (x, y) [m s], and
    ``done`` (within ``stop_radius``: stop, no intermediate goal to follow)."""

    x: float
    y: float
    yaw: float
    distance: float
    integral: tuple[float, float]
    done: bool


class GpsChasePI:
    """Feed it the goal and the position every cycle; :meth:`reset` for a new goal."""

    def __init__(self, params: GpsChaseParams | None = None) -> None:
        self.params = params or GpsChaseParams()
        self.integral = (0.0, 0.0)

    def reset(self) -> None:
        self.integral = (0.0, 0.0)

    def step(self, goal: tuple[float, float], position: tuple[float, float], dt: float
             ) -> ChaseStep:
        """The intermediate goal after ``dt`` [s] (>= 0) with the goal and the rover's
        position in one frame [m]."""
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f"dt must be a finite time step >= 0 s, not {dt!r}")
        p = self.params
        ex, ey = goal[0] - position[0], goal[1] - position[1]
        distance = math.hypot(ex, ey)
        if not math.isfinite(distance):
            raise ValueError(f"non-finite goal {goal} or position {position}")
        heading = math.atan2(ey, ex) if distance > 1e-9 else 0.0
        if distance <= p.stop_radius:
            self.reset()
            return ChaseStep(position[0], position[1], heading, distance, self.integral, True)
        if distance <= p.windup_radius or ex * self.integral[0] + ey * self.integral[1] < 0.0:
            self.integral = (0.0, 0.0)  # anti-windup: near the goal, or past it
        else:
            ix, iy = self.integral[0] + ex * dt, self.integral[1] + ey * dt
            norm = math.hypot(ix, iy) * p.ki
            if norm > p.max_integral:  # cap the integral's contribution
                ix, iy = ix * p.max_integral / norm, iy * p.max_integral / norm
            self.integral = (ix, iy)
        ox = p.kp * ex + p.ki * self.integral[0]
        oy = p.kp * ey + p.ki * self.integral[1]
        length = math.hypot(ox, oy)
        target = min(max(length, p.min_step), p.max_step)
        if length > 1e-9:
            ox, oy = ox * target / length, oy * target / length
        return ChaseStep(position[0] + ox, position[1] + oy, heading, distance,
                         self.integral, False)

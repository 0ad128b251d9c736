"""``ExploreParams``: explore_lite's parameters, by name and meaning, plus navstack's.

explore_lite (m-explore ``explore`` node, ROS 1 and ROS 2 ports):

* ``planner_frequency`` [Hz]: how often frontiers are searched and the goal reconsidered;
* ``progress_timeout`` [s]: a goal during which the robot got no closer to its frontier
  for this long is blacklisted;
* ``potential_scale``, ``gain_scale``, ``orientation_scale``: weights of the frontier
  cost ``potential_scale * distance - gain_scale * size + orientation_scale * turn``;
* ``min_frontier_size`` [m]: frontiers shorter than this are ignored;
* ``return_to_init``: go back to the start pose when no frontier is left;
* ``visualize``: publish the frontiers as a ``MarkerArray`` (``explore/frontiers``);
* ``costmap_topic``: the grid frontiers are searched on (explore_lite: ``costmap``).

The defaults are explore_lite's (``potential_scale`` 1e-3, ``orientation_scale`` 0,
``gain_scale`` 1, ``min_frontier_size`` 0.5, ``progress_timeout`` 30, ``planner_frequency``
1) -- also the TurtleBot course's values.  The navstack additions (``strategy`` and below)
are what keeps explore_lite's known failure modes away; docs/missions.md explains each.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from navstack.core.params import Params

__all__ = ["ExploreParams", "StrategyName"]

StrategyName = Literal["explore_lite", "information_gain", "nearest"]


class ExploreParams(Params):
    """explore_lite parameters plus navstack's (module docstring)."""

    # --- explore_lite ---
    planner_frequency: float = Field(1.0, gt=0.0)
    progress_timeout: float = Field(30.0, gt=0.0)
    potential_scale: float = Field(1e-3, ge=0.0)
    orientation_scale: float = Field(0.0, ge=0.0)
    gain_scale: float = Field(1.0, ge=0.0)
    min_frontier_size: float = Field(0.5, ge=0.0)
    return_to_init: bool = True
    visualize: bool = True
    costmap_topic: str = "/global_costmap/costmap"
    robot_base_frame: str = "base_link"
    # --- navstack ---
    look_around_at_home: bool = True
    """With ``return_to_init``: on arriving home, turn a full circle before judging the
    distance, then drive back if the estimate moved (SLAM closes its loop with the start's
    scans during the turn; :class:`~navstack.missions.behaviours.ReturnHome`)."""
    strategy: StrategyName = "information_gain"
    """``explore_lite``: the cost above; ``information_gain``: visible unknown area
    discounted by path distance; ``nearest``: Yamauchi's nearest frontier
    (strategies.py)."""
    lethal_threshold: int = Field(99, ge=1, le=100)
    """Costmap-topic value (0..100) from which the robot centre may not go."""
    occupied_threshold: int = Field(100, ge=1, le=100)
    """Value from which a cell is an obstacle rather than free (frontiers border free)."""
    frontier_reach: float = Field(0.3, gt=0.0)
    """A frontier is approached from traversable cells within this distance [m]."""
    goal_clearance: float | None = Field(None, ge=0.0)
    """Send goals only where the robot can turn round: at least this far [m] from every
    obstacle (frontiers.py).  ``None``: the robot footprint's circumscribed radius in a
    mission (the explorer alone: 0, off)."""
    goal_reach: float = Field(1.0, gt=0.0)
    """How far [m] from a frontier a roomy goal may be (when none is within
    ``frontier_reach``); it must see the frontier."""
    blacklist_tolerance: float = Field(0.25, ge=0.0)
    """Blacklisted frontier cells are grown by this [m] (explore_lite: 5 cells)."""
    max_goal_attempts: int = Field(2, ge=1)
    """A blacklisted frontier that is still reachable is retried, up to this many goals in
    all, before exploration may end with it unexplored."""
    stuck_timeout: float = Field(15.0, gt=0.0)
    stuck_distance: float = Field(0.25, gt=0.0)
    """A goal during which the robot moved less than ``stuck_distance`` [m] in
    ``stuck_timeout`` [s] (turning in place, recovering) is abandoned and blacklisted."""
    stuck_blame_distance: float = Field(3.0, gt=0.0)
    """A goal abandoned as stuck (above) while the robot was farther than this [m,
    straight line] from it counts as the robot's failure on the way, not the frontier's:
    its frontier is set aside and retried like a blacklisted one, but the try does not
    count toward ``max_goal_attempts`` (at most ``2 * max_goal_attempts`` tries in all).
    navstack: explore_lite blames the frontier for any goal that makes no progress."""
    arrival_settle_time: float = Field(2.0, ge=0.0)
    """After a goal is reached, the map this much later decides whether its frontier was
    explored; if not, the frontier is blacklisted (it cannot be seen from there)."""
    start_search_radius: float = Field(1.0, gt=0.0)
    """The wavefront starts from the nearest traversable cell within this radius [m] when
    the robot's own cell is not traversable."""
    # information-gain strategy
    distance_decay: float = Field(0.35, ge=0.0)
    """lambda of ``gain * exp(-lambda * distance)`` [1/m]."""
    sensor_range: float = Field(3.5, gt=0.0)
    """Range [m] of the gain raycast (the lidar's usable range)."""
    viewpoint_spacing: float = Field(0.5, gt=0.0)
    """Candidate viewpoints along a frontier, one per this many metres."""
    turn_distance: float = Field(0.26, ge=0.0)
    """Information gain: a viewpoint's path distance is lengthened by this many metres
    per radian the robot must turn to head for it -- the distance it would have driven
    in that time (TurtleBot3: RPP drives 0.26 m/s and turns in place at 1.0 rad/s).
    Next targets ahead of the robot win over equal ones behind it."""
    path_gain: bool = True
    """Information gain: a target's gain is the unknown area visible from its path (one
    point per ``viewpoint_spacing``) and goal, not from the goal alone."""
    retarget_hysteresis: float = Field(0.25, ge=0.0)
    """The current target is kept unless another scores this fraction better."""
    lookahead_distance: float = Field(1.0, ge=0.0)
    """Information gain: once the robot is this close [m, path] to its goal, the next
    target is sent -- the robot moves on instead of slowing to a stop at every viewpoint
    (the controller slows down near a goal); the target it leaves is judged like a
    reached one.  0 turns the look-ahead off."""
    lookahead_gain_fraction: float = Field(0.5, ge=0.0, le=1.0)
    """... but only once the unknown area still visible from the goal is at most this
    fraction of what it was when the goal was chosen (1: distance alone)."""

"""Ready-made MPPI configurations in Nav2's ``FollowPath`` layout.

:func:`golf_cart_mppi_params` is a campus golf cart (Ackermann, 5 m turning radius,
2.5 m/s): a long horizon (56 steps x 0.1 s = 5.6 s, so the controller runs at 10 Hz and
shifts its control sequence), 2000 samples, and Nav2's README critic set with a strong
PathAlign term for lane-keeping.  Things that scale with speed are scaled from Nav2's
TurtleBot defaults: wider velocity sampling (``vx_std``), the pruned plan reaches
beyond the stopping distance (``prune_distance``), path-point offsets cover ~30 % of the
distance driven over the horizon.  The local costmap must cover the horizon too
(2.5 m/s x 5.6 s = 14 m ahead; e.g. a 30 m x 30 m rolling window at 0.1 m), since
MPPI's critics treat poses off the costmap as collisions unless it tracks unknown space.

:data:`GOLF_CART_MPPI_YAML` is the same as a YAML snippet to paste under
``controller_server: ros__parameters:``.
"""

from __future__ import annotations

from typing import Any


def golf_cart_mppi_params() -> dict[str, Any]:
    """The golf-cart ``FollowPath`` section as the cart team configured it (a fresh dict
    each call).  ``config/golf_cart_nav2_params.yaml``, which ``navstack demo --robot
    golf_cart`` runs, starts from it and departs where the campus runs showed it must
    (``min_turning_r`` 3.0, GoalAngleCritic, CostCritic ``consider_footprint``); the
    reasons are comments in that file."""
    return {
        "plugin": "nav2_mppi_controller::MPPIController",
        "time_steps": 56,
        "model_dt": 0.1,
        "batch_size": 2000,
        "iteration_count": 1,
        "vx_std": 0.4,
        "vy_std": 0.0,
        "wz_std": 0.3,
        "vx_max": 2.5,
        "vx_min": -0.35,
        "vy_max": 0.0,
        "wz_max": 1.9,
        "ax_max": 1.5,
        "ax_min": -2.5,
        "ay_max": 0.0,
        "ay_min": 0.0,
        "az_max": 1.5,
        "temperature": 0.3,
        "gamma": 0.015,
        "motion_model": "Ackermann",
        "AckermannConstraints": {"min_turning_r": 5.0},
        "shift_control_sequence": True,
        "prune_distance": 8.0,
        "visualize": False,
        "regenerate_noises": False,
        "retry_attempt_limit": 1,
        "critics": ["ConstraintCritic", "CostCritic", "GoalCritic", "GoalAngleCritic",
                    "PathAlignCritic", "PathFollowCritic", "PathAngleCritic",
                    "PreferForwardCritic"],
        "ConstraintCritic": {"enabled": True, "cost_power": 1, "cost_weight": 4.0},
        "CostCritic": {"enabled": True, "cost_power": 1, "cost_weight": 3.81,
                       "critical_cost": 300.0, "consider_footprint": False,
                       "collision_cost": 1000000.0, "near_goal_distance": 1.0,
                       "trajectory_point_step": 2, "inflation_radius": 1.5,
                       "cost_scaling_factor": 3.0},
        "GoalCritic": {"enabled": True, "cost_power": 1, "cost_weight": 5.0,
                       "threshold_to_consider": 1.4},
        "GoalAngleCritic": {"enabled": True, "cost_power": 1, "cost_weight": 3.0,
                            "threshold_to_consider": 0.5},
        "PreferForwardCritic": {"enabled": True, "cost_power": 1, "cost_weight": 5.0,
                                "threshold_to_consider": 0.5},
        "PathAlignCritic": {"enabled": True, "cost_power": 1, "cost_weight": 14.0,
                            "max_path_occupancy_ratio": 0.05, "trajectory_point_step": 4,
                            "threshold_to_consider": 0.5, "offset_from_furthest": 20,
                            "use_path_orientations": False},
        "PathFollowCritic": {"enabled": True, "cost_power": 1, "cost_weight": 5.0,
                             "offset_from_furthest": 5, "threshold_to_consider": 1.4},
        "PathAngleCritic": {"enabled": True, "cost_power": 1, "cost_weight": 2.0,
                            "offset_from_furthest": 4, "threshold_to_consider": 0.5,
                            "max_angle_to_furthest": 1.0, "mode": 0},
    }


GOLF_CART_MPPI_YAML = """\
FollowPath:
  plugin: "nav2_mppi_controller::MPPIController"
  time_steps: 56
  model_dt: 0.1
  batch_size: 2000
  iteration_count: 1
  vx_std: 0.4
  vy_std: 0.0
  wz_std: 0.3
  vx_max: 2.5
  vx_min: -0.35
  vy_max: 0.0
  wz_max: 1.9
  ax_max: 1.5
  ax_min: -2.5
  ay_max: 0.0
  ay_min: 0.0
  az_max: 1.5
  temperature: 0.3
  gamma: 0.015
  motion_model: "Ackermann"
  AckermannConstraints:
    min_turning_r: 5.0
  shift_control_sequence: true
  prune_distance: 8.0
  visualize: false
  regenerate_noises: false
  retry_attempt_limit: 1
  critics: ["ConstraintCritic", "CostCritic", "GoalCritic", "GoalAngleCritic",
            "PathAlignCritic", "PathFollowCritic", "PathAngleCritic", "PreferForwardCritic"]
  ConstraintCritic: {enabled: true, cost_power: 1, cost_weight: 4.0}
  CostCritic:
    enabled: true
    cost_power: 1
    cost_weight: 3.81
    critical_cost: 300.0
    consider_footprint: false
    collision_cost: 1000000.0
    near_goal_distance: 1.0
    trajectory_point_step: 2
    inflation_radius: 1.5
    cost_scaling_factor: 3.0
  GoalCritic: {enabled: true, cost_power: 1, cost_weight: 5.0, threshold_to_consider: 1.4}
  GoalAngleCritic: {enabled: true, cost_power: 1, cost_weight: 3.0, threshold_to_consider: 0.5}
  PreferForwardCritic:
    enabled: true
    cost_power: 1
    cost_weight: 5.0
    threshold_to_consider: 0.5
  PathAlignCritic:
    enabled: true
    cost_power: 1
    cost_weight: 14.0
    max_path_occupancy_ratio: 0.05
    trajectory_point_step: 4
    threshold_to_consider: 0.5
    offset_from_furthest: 20
    use_path_orientations: false
  PathFollowCritic:
    enabled: true
    cost_power: 1
    cost_weight: 5.0
    offset_from_furthest: 5
    threshold_to_consider: 1.4
  PathAngleCritic:
    enabled: true
    cost_power: 1
    cost_weight: 2.0
    offset_from_furthest: 4
    threshold_to_consider: 0.5
    max_angle_to_furthest: 1.0
    mode: 0
"""
"""YAML form of :func:`golf_cart_mppi_params` (a test checks they agree)."""

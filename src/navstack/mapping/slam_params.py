"""SLAM parameters, named and defaulted as slam_toolbox's ``mapper_params_*.yaml``.

A slam_toolbox parameter file (``slam_toolbox: ros__parameters: ...``) loads unchanged.
Two knobs keep slam_toolbox's name but not its default, for the reasons given:

* ``correlation_search_space_resolution`` 0.02 m (slam_toolbox 0.01): the correlative
  search only has to land in the right cell; a Gauss-Newton refinement on the smeared
  grid then gives sub-cell accuracy (docs/decisions.md, "SLAM matcher"), and a 0.02 m grid
  is four times cheaper to build.
* ``correlation_search_space_smear_deviation`` 0.05 m (slam_toolbox 0.1): measured on
  the Intel log, 0.1 blurs the walls enough to raise the relative pose error by 30%.
* ``scan_buffer_size`` 15 (slam_toolbox 10): a longer local map; on CSAIL the error over
  ten scans fell from 0.098 to 0.07 m (docs/mapping.md).
* ``loop_search_space_dimension`` 2.0 m (slam_toolbox 8.0) is the *smallest* loop search
  window: the window follows the graph's uncertainty
  (:mod:`navstack.mapping.loop_closure`), up to ``loop_search_maximum_space_dimension``.
* ``loop_search_space_smear_deviation`` 0.05 m (slam_toolbox 0.03): the loop grids'
  responses are compared with the link matcher's thresholds, so they smear alike.

The navstack additions (every one documented in docs/mapping.md) are commented below.

The Ceres solver keys are accepted so slam_toolbox files load; the back end is gtsam
(:mod:`navstack.mapping.pose_graph`), so they have no effect, and
:func:`unused_solver_keys` lists them for a log line.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from navstack.core.params import Params
from navstack.mapping.occupancy import free_thresh_after

__all__ = ["SlamParams", "unused_solver_keys"]

_CERES_KEYS = ("solver_plugin", "ceres_linear_solver", "ceres_preconditioner",
               "ceres_trust_strategy", "ceres_dogleg_type", "ceres_loss_function")


class SlamParams(Params):
    """slam_toolbox parameters (names from ``slam_toolbox/config/mapper_params_online_*``)."""

    # --- toolbox / ROS side ---
    mode: Literal["mapping", "localization"] = "mapping"
    odom_frame: str = "odom"
    map_frame: str = "map"
    base_frame: str = "base_link"
    scan_topic: str = "/scan"
    use_map_saver: bool = True
    map_file_name: str = ""
    map_start_pose: list[float] | None = None
    map_start_at_dock: bool | None = None
    # navstack: the published map covers at least [xmin, ymin, xmax, ymax] (unknown where
    # unseen) so that goals in unexplored space lie inside the costmap (slam_node.py)
    map_minimum_extent: list[float] | None = None
    debug_logging: bool = False
    throttle_scans: int = Field(1, ge=1)
    transform_publish_period: float = Field(0.02, ge=0.0)
    map_update_interval: float = Field(5.0, gt=0.0)
    resolution: float = Field(0.05, gt=0.0)
    # navstack: the published and saved map show a cell free once this many scans more
    # crossed it than ended in it (occupancy.free_thresh_after).  Karto's map does after
    # 2 ray passes (MinPassThrough); map_server's free_thresh 0.196 would need 4 scans,
    # which left /map about a metre of travel behind the costmaps (docs/mapping.md)
    map_free_scans: int = Field(2, ge=1)
    min_laser_range: float = Field(0.0, ge=0.0)
    max_laser_range: float = Field(20.0, gt=0.0)
    minimum_time_interval: float = Field(0.5, ge=0.0)
    transform_timeout: float = Field(0.2, ge=0.0)
    tf_buffer_duration: float = Field(30.0, gt=0.0)
    stack_size_to_use: int = 40000000
    enable_interactive_mode: bool = True
    scan_queue_size: int = Field(1, ge=1)
    use_sim_time: bool = True
    # synchronous: every accepted scan is processed; asynchronous: only the newest scan is
    # processed when the mapper is free (slam_toolbox's sync / async nodes)
    synchronous: bool = True

    # --- Karto matcher ---
    use_scan_matching: bool = True
    use_scan_barycenter: bool = True
    # navstack: polish every match with point-to-line ICP (mapping/icp.py)
    use_point_to_line_refinement: bool = True
    minimum_travel_distance: float = Field(0.5, ge=0.0)
    minimum_travel_heading: float = Field(0.5, ge=0.0)
    scan_buffer_size: int = Field(15, ge=1)
    scan_buffer_maximum_scan_distance: float = Field(10.0, gt=0.0)
    link_match_minimum_response_fine: float = Field(0.1, ge=0.0, le=1.0)
    link_scan_maximum_distance: float = Field(1.5, ge=0.0)
    loop_search_maximum_distance: float = Field(3.0, ge=0.0)
    do_loop_closing: bool = True
    loop_match_minimum_chain_size: int = Field(10, ge=1)
    loop_match_maximum_variance_coarse: float = Field(3.0, gt=0.0)
    loop_match_minimum_response_coarse: float = Field(0.35, ge=0.0, le=1.0)
    loop_match_minimum_response_fine: float = Field(0.45, ge=0.0, le=1.0)
    correlation_search_space_dimension: float = Field(0.5, gt=0.0)
    correlation_search_space_resolution: float = Field(0.02, gt=0.0)
    correlation_search_space_smear_deviation: float = Field(0.05, gt=0.0)
    loop_search_space_dimension: float = Field(2.0, gt=0.0)
    loop_search_space_resolution: float = Field(0.05, gt=0.0)
    loop_search_space_smear_deviation: float = Field(0.05, gt=0.0)
    distance_variance_penalty: float = Field(0.5, gt=0.0)
    angle_variance_penalty: float = Field(1.0, gt=0.0)
    fine_search_angle_offset: float = Field(0.00349, gt=0.0)
    coarse_search_angle_offset: float = Field(0.349, ge=0.0)
    coarse_angle_resolution: float = Field(0.0349, gt=0.0)
    minimum_angle_penalty: float = Field(0.9, ge=0.0, le=1.0)
    minimum_distance_penalty: float = Field(0.5, ge=0.0, le=1.0)
    use_response_expansion: bool = True
    # navstack: uniqueness test of loop closures (not in slam_toolbox; see slam.py)
    loop_match_maximum_ambiguity: float = Field(0.8, gt=0.0, le=1.0)
    loop_match_ambiguity_distance: float = Field(0.5, gt=0.0)
    # navstack: a closure may not correct more than base + rate * path length since the
    # matched scan (scan-matched odometry drifts < 1% on the CARMEN logs), and loop edges
    # carry a Cauchy kernel of this many sigmas (0 = none)
    loop_match_maximum_drift_base: float = Field(0.3, gt=0.0)
    loop_match_maximum_drift_rate: float = Field(0.05, ge=0.0)
    loop_closure_robust_kernel: float = Field(1.0, ge=0.0)
    # navstack: global loop closure (mapping/loop_closure.py, docs/mapping.md): the
    # kernel of loop edges (and of links, 0 = none), the search region and window in
    # sigmas of the relative covariance, at most that big, the smallest angular window,
    # candidates per node, nodes per submap, corridor closures, closures confirmed by
    # another within this many nodes, a submap tried at most every this many nodes, the
    # residual of a closure after a batch optimisation above which it is removed, and
    # the correction that triggers a batch optimisation [m]
    loop_closure_robust_kernel_type: Literal["cauchy", "huber", "dcs"] = "cauchy"
    link_match_robust_kernel: float = Field(0.0, ge=0.0)
    loop_search_drift_sigmas: float = Field(3.0, ge=0.0)
    loop_search_maximum_space_dimension: float = Field(60.0, gt=0.0)
    loop_search_minimum_angle_offset: float = Field(0.1, gt=0.0)
    loop_search_maximum_candidates: int = Field(1, ge=1)
    loop_match_submap_size: int = Field(10, ge=1)
    loop_match_corridor_closures: bool = True
    loop_match_confirmation_nodes: int = Field(5, ge=0)
    # navstack: the agreeing closure must be against another submap: two closures against
    # one submap see its aliases alike (docs/mapping.md "Aliased closures")
    loop_match_confirmation_distinct_submaps: bool = True
    # navstack: ... except that two agreeing closures against one submap confirm each
    # other when neither moves its node farther than this [m] (0 = off): where only one
    # submap is in view (back at the start, turning on the spot) nothing else can
    # confirm, and a closure that small cannot carry an alias's error in
    # (mapping/loop_closure.py, docs/mapping.md "Back at the start")
    loop_match_same_submap_confirmation_distance: float = Field(0.0, ge=0.0)
    loop_search_node_interval: int = Field(3, ge=1)
    loop_closure_maximum_chi2: float = Field(200.0, gt=0.0)
    # navstack: a closure's fine response must reach this share of the ordinary links'
    # typical (median) response (0 = off): partial views fit biased (docs/mapping.md)
    loop_match_minimum_response_ratio: float = Field(0.75, ge=0.0, le=1.0)
    # navstack: a closure whose scan, at the matched pose, passes through the submap's
    # static structure on more than this many beams per beam that lands on it is an
    # alias and rejected (0 = off; mapping/loop_closure.py, docs/mapping.md "Aliased
    # closures")
    loop_match_maximum_seen_through_ratio: float = Field(0.3, ge=0.0)
    # navstack: a (non-corridor) closure whose position lies farther from the window's
    # centre than this share of the window's half-size on either axis is rejected: the
    # score still rose towards the edge, the optimum may lie outside -- in a warehouse
    # aisle the match slid along the racks (0 = off; docs/mapping.md "Loop windows")
    loop_match_maximum_window_fraction: float = Field(0.0, ge=0.0, le=1.0)
    loop_closure_batch_distance: float = Field(0.5, gt=0.0)
    # navstack: odometry edges where a match is degenerate and their initial noise
    # (fractions of the motion), the speed and turn rate odometry may not exceed, the
    # wide search's radius limits [m] and the response ratio the local match must keep
    # against it (mapping/odometry_check.py, mapping/recovery.py)
    use_odometry_edges: bool = True
    # navstack: rescale an odometry edge's translation by the scale learned from
    # well-conditioned matches (odometry_check.OdometryNoise); the log profile turns it
    # on -- online it made the worn-odometry office route worse (docs/mapping.md)
    odometry_scale_correction: bool = False
    # navstack: an odometry edge informs only the match's weak directions (log profile
    # on; online it made the office waypoint route fail two goals, docs/mapping.md)
    odometry_edge_weak_directions: bool = False
    odometry_linear_error: float = Field(0.05, ge=0.0)
    odometry_angular_error: float = Field(0.05, ge=0.0)
    # navstack: the odometry edge's standard deviation per step before the learned part
    # [m], [rad] (odometry_check.OdometryNoise)
    odometry_linear_error_floor: float = Field(0.02, gt=0.0)
    odometry_angular_error_floor: float = Field(0.017453292519943295, gt=0.0)
    odometry_maximum_speed: float = Field(1.0, gt=0.0)
    odometry_maximum_turn_rate: float = Field(3.0, gt=0.0)
    recovery_search_minimum_distance: float = Field(1.0, gt=0.0)
    recovery_search_maximum_distance: float = Field(5.0, gt=0.0)
    recovery_response_ratio: float = Field(0.6, ge=0.0, le=1.0)
    # navstack: give every scan that is not a node a pose by a local match (offline runs
    # score every scan); slam_toolbox drops them
    match_skipped_scans: bool = False
    # navstack: reference points a new scan sees through by more than this margin [m]
    # (+ 2% of their range) are left out of its scan match -- people walking, see
    # mapping/free_space.py; 0 = off (slam_toolbox's behaviour)
    dynamic_point_margin: float = Field(0.2, ge=0.0)
    # navstack: match a new scan only with its points within (usable range - this) of a
    # reference scan's laser, i.e. where the references could have seen something; 0 =
    # every point (Karto).  Removes the pull back along walls that run out of range (a
    # corridor longer than a 3.5 m LDS), see slam.py
    link_match_coverage_margin: float = Field(0.0, ge=0.0)
    # navstack, for short-range lidars (docs/mapping.md, "Sparse scans"; the TurtleBot3
    # LDS profile turns these on, 0 / off = Karto's behaviour):
    # - a link match whose Gauss-Newton covariance is this many times longer (standard
    #   deviations, in match units) in its weakest direction than in its strongest is
    #   scored along that direction and its covariance widened there
    #   (scan_matcher.coupled_covariance: a lone cluster of returns lets the scan turn
    #   about it, which the x / y / theta response surface cannot see)
    link_match_coupled_variance_ratio: float = Field(0.0, ge=0.0)
    # - a link match this degenerate (weakest / strongest standard deviation) is fused
    #   with the odometry's prediction by their information (its flat directions take
    #   the odometry's; Zhang, Kaess & Singh, ICRA 2016)
    link_match_weak_direction_ratio: float = Field(0.0, ge=0.0)
    # - a scan with fewer returns in range than this is not matched when its odometry is
    #   trusted: placed by the odometry with the odometry's covariance
    link_match_minimum_points: int = Field(0, ge=0)
    # - an odometry edge on every matched link (Cartographer's odometry constraints
    #   between consecutive nodes), not only where the match is degenerate
    odometry_edges_on_every_link: bool = False
    # - learn the odometry's noise from degenerate matches too (false: from
    #   well-conditioned ones only, as the scale)
    odometry_noise_from_degenerate_matches: bool = True
    # - the Cauchy kernel of odometry edges, in sigmas (0 = none)
    odometry_edge_robust_kernel: float = Field(1.0, ge=0.0)

    # --- solver (accepted for slam_toolbox files; the back end is gtsam) ---
    solver_plugin: str = "solver_plugins::CeresSolver"
    ceres_linear_solver: str = "SPARSE_NORMAL_CHOLESKY"
    ceres_preconditioner: str = "SCHUR_JACOBI"
    ceres_trust_strategy: str = "LEVENBERG_MARQUARDT"
    ceres_dogleg_type: str = "TRADITIONAL_DOGLEG"
    ceres_loss_function: str = "None"

    @property
    def map_free_thresh(self) -> float:
        """The ``free_thresh`` the map is rendered and saved with (``map_free_scans``)."""
        return free_thresh_after(self.map_free_scans)


def unused_solver_keys(params: SlamParams) -> list[str]:
    """The Ceres keys the user set explicitly (they have no effect with gtsam)."""
    return [key for key in _CERES_KEYS if key in params.model_fields_set]

"""Graph SLAM from laser scans and odometry, the Karto / slam_toolbox way, with global loop
closure.

Per scan (:meth:`SlamMapper.process_scan`):

1. *gating* (slam_toolbox semantics): a scan becomes a graph node only after
   ``minimum_travel_distance`` or ``minimum_travel_heading`` of odometry motion and
   ``minimum_time_interval`` (``throttle_scans``).  A skipped scan costs a comparison,
   or one local match when ``match_skipped_scans`` asks for a pose of every scan;
2. *odometry check* (:mod:`navstack.mapping.odometry_check`): missing odometry, a gap the
   caller reports, an increment faster than ``odometry_maximum_speed`` /
   ``odometry_maximum_turn_rate`` allow.  A scan with no odometry at all while the
   stream goes on is only registered (never a node); one after a gap is predicted by the
   last motion repeated;
3. *linking*: the scan is matched against the *running buffer* (the last
   ``scan_buffer_size`` nodes within ``scan_buffer_maximum_scan_distance``) with the
   correlative matcher (:mod:`navstack.mapping.scan_matcher`) around the prediction.
   When the odometry is missing or suspect, or the local match fails, a *wide* search
   (full circle, as far as the robot could have moved; :mod:`navstack.mapping.recovery`)
   runs too and the better fit wins (the local one unless it is below
   ``recovery_response_ratio`` times the wide one); the scan is flagged in
   :class:`SlamStats`.  The link's covariance is the match's response surface
   (:meth:`SlamMapper._link_covariance`); where it is degenerate (a corridor, an open
   hall) an odometry edge is added too (``use_odometry_edges``, with noise learned from
   the odometry's disagreement with the matches).  Reference points the new scan sees
   through at the predicted pose by more than ``dynamic_point_margin`` (a person who
   walked on) are left out of the link match (:mod:`navstack.mapping.free_space`);
4. *loop closure* against submaps, with a window that grows with the graph's marginal
   covariance (:mod:`navstack.mapping.loop_closure`);
5. *optimisation*: ISAM2 every node (gtsam, :mod:`navstack.mapping.pose_graph`); when a
   closure moves the current pose by more than ``loop_closure_batch_distance`` a batch
   Levenberg-Marquardt follows.  Closures whose residual after optimisation exceeds
   ``loop_closure_maximum_chi2`` are removed again.

``map -> odom`` is the last node's map pose composed with the inverse of its odometry pose.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import se2_between, se2_compose, se2_inverse
from navstack.mapping.fast_matcher import voxel_filter
from navstack.mapping.free_space import seen_through
from navstack.mapping.icp import line_normals, refine_point_to_line
from navstack.mapping.loop_closure import LoopCloser, tangent_covariance
from navstack.mapping.occupancy import LogOddsGrid
from navstack.mapping.odometry_check import OdometryCheck, OdometryNoise, odometry_verdict
from navstack.mapping.pose_graph import PoseGraph
from navstack.mapping.recovery import predicted_link, wide_link
from navstack.mapping.scan_matcher import (
    LikelihoodGrid,
    MatchResult,
    SearchWindow,
    coupled_covariance,
    match_scan,
    response_covariance,
)
from navstack.mapping.slam_links import (
    GAP_STRONG_RESPONSE,
    degenerate,
    distance,
    fuse,
    gap_choice,
    weak_part,
)
from navstack.mapping.slam_maps import NodeMaps
from navstack.mapping.slam_params import SlamParams

FloatArray = NDArray[np.float64]
#: a link's angular search covers this many standard deviations of the odometry's
#: rotation error over the step (at least ``coarse_search_angle_offset``)
LINK_WINDOW_SIGMAS = 3.0
#: a scan without odometry is predicted by the last motion, its translation scaled by
#: the elapsed time at most this many times (:meth:`SlamMapper._motion_prediction`)
PREDICTION_MAXIMUM_SCALE = 1.5
#: the robot's seen speed and step (:meth:`SlamMapper._seen_speed`, ``_seen_step``)
#: bound the wide search once this many were measured.  Ten let the first gap scans of
#: a slow robot be searched ``odometry_maximum_speed`` times the gap away (Intel with
#: every second interval's odometry removed: scan 13 was placed 4 m along a corridor,
#: the next 18 scans followed it; ATE 0.34 -> 0.25 m with three)
SEEN_MOTION_MINIMUM_SAMPLES = 3

__all__ = ["LaserGeometry", "ScanNode", "SlamMapper", "SlamStats"]


@dataclass(frozen=True)
class LaserGeometry:
    """Beam angles and limits of the laser, and its mount pose in the base frame."""

    angles: FloatArray
    range_min: float
    range_max: float
    mount: FloatArray = field(default_factory=lambda: np.zeros(3))

    @classmethod
    def uniform(cls, angle_min: float, angle_increment: float, count: int, range_min: float,
                range_max: float,
                mount: Sequence[float] | FloatArray = (0.0, 0.0, 0.0)) -> LaserGeometry:
        angles = (angle_min + angle_increment * np.arange(count)).astype(np.float64)
        return cls(angles, float(range_min), float(range_max), np.asarray(mount, float))


@dataclass
class ScanNode:
    """A processed scan: graph node id, odometry pose (NaN when it had none), stamp."""

    node_id: int
    odom: FloatArray
    stamp: float
    ranges: NDArray[np.float32]
    points: FloatArray  # matching points in the base frame
    normals: FloatArray  # their local line normals (base frame), see mapping/icp.py
    line_like: NDArray[np.bool_]


@dataclass
class SlamStats:
    """Counters for health checks, benchmarks and the run summary."""

    scans_received: int = 0
    scans_processed: int = 0
    match_failures: int = 0
    loop_closures: int = 0
    loop_attempts: int = 0
    loop_ambiguous: int = 0
    loop_implausible: int = 0
    loop_weak: int = 0
    loop_corridor: int = 0
    loop_rejected_outliers: int = 0
    #: closures whose scan saw through the submap's static structure (aliases)
    loop_seen_through: int = 0
    #: closures found at the edge of their search window (``loop_match_maximum_window_fraction``)
    loop_window_edge: int = 0
    loop_unconfirmed: int = 0
    batch_optimizations: int = 0
    odometry_missing: int = 0
    odometry_implausible: int = 0
    wide_searches: int = 0
    wide_recoveries: int = 0
    unlinked_nodes: int = 0
    odometry_edges: int = 0
    #: nodes placed by odometry alone: fewer than ``link_match_minimum_points`` returns
    sparse_nodes: int = 0
    #: (scan number, reason) of every scan whose odometry was missing or not trusted
    odometry_events: list[tuple[int, str]] = field(default_factory=list)
    #: scan numbers placed by the wide search rather than the local match
    recovered_scans: list[int] = field(default_factory=list)
    #: scan numbers without odometry over their step whose wide search was ambiguous
    #: (several fits within the reach; placed by
    #: :func:`~navstack.mapping.slam_links.gap_choice`, tied robustly)
    ambiguous_scans: list[int] = field(default_factory=list)




class SlamMapper:
    """Online pose-graph SLAM; feed :meth:`process_scan`, read poses / map / ``map->odom``."""

    def __init__(self, params: SlamParams, laser: LaserGeometry) -> None:
        self.params = params
        self.laser = laser
        self.graph = PoseGraph()
        self.nodes: list[ScanNode] = []
        self.stats = SlamStats()
        #: node id and pose relative to it of the last scan given to process_scan
        self.last_scan: tuple[int, FloatArray] | None = None
        self._running: list[int] = []
        self._last_accepted_odom: FloatArray | None = None
        self._last_accepted_stamp = -math.inf
        self._last_node_stamp = -math.inf
        self._map_to_odom = np.zeros(3)
        self._world_cache: dict[int, tuple[FloatArray, FloatArray]] = {}
        self._local_cache: tuple[Any, tuple[FloatArray, FloatArray, NDArray[np.bool_],
                                            LikelihoodGrid | None]] | None = None
        self._poses = np.zeros((0, 3))
        self._covs = np.zeros((0, 3, 3))
        self.frozen_nodes = 0  # nodes loaded for localization: matched against, never moved
        self._window = SearchWindow(
            dimension=params.correlation_search_space_dimension,
            coarse_angle_offset=params.coarse_search_angle_offset,
            coarse_angle_resolution=params.coarse_angle_resolution,
            fine_angle_resolution=params.fine_search_angle_offset,
            distance_variance_penalty=params.distance_variance_penalty,
            angle_variance_penalty=params.angle_variance_penalty,
            minimum_distance_penalty=params.minimum_distance_penalty,
            minimum_angle_penalty=params.minimum_angle_penalty)
        # refining a branch-and-bound result: it is within a cell and an angle step
        self.refine_window = SearchWindow(
            dimension=4.0 * params.loop_search_space_resolution, coarse_angle_offset=0.035,
            coarse_angle_resolution=0.00873, fine_angle_resolution=params.fine_search_angle_offset,
            distance_variance_penalty=params.distance_variance_penalty,
            angle_variance_penalty=params.angle_variance_penalty,
            minimum_distance_penalty=params.minimum_distance_penalty,
            minimum_angle_penalty=params.minimum_angle_penalty)
        self._loops = LoopCloser(self)
        self._odometry_noise = OdometryNoise(params)
        self._unplaced: set[int] = set()   # nodes the wide search could not place
        self._gap_before: dict[int, bool] = {}  # node -> its odometry had a gap before it
        self._last_placed = 0
        self._speeds: list[float] = []   # speeds between placed nodes seen [m/s]
        self._steps: list[float] = []    # distances between placed nodes seen [m]
        self._responses: list[float] = []  # responses of the last ordinary links
        self._closure_edges: list[int] = []  # edge numbers of the loop closures
        self._closure_events = 0
        self.maps = NodeMaps(params, laser)
        """The node scans drawn into maps (:meth:`live_map`, :meth:`build_map`)."""
        self._scan_count = 0
        self._start_override: FloatArray | None = None
        self._restart = False  # next scan starts a new odometry frame (after a reload)

    # --- state -----------------------------------------------------------------------
    @property
    def map_to_odom(self) -> FloatArray:
        """The current ``map -> odom`` transform (x, y, yaw)."""
        return self._map_to_odom.copy()

    def poses(self) -> FloatArray:
        """Map poses of all nodes (N, 3), in node order."""
        if not self.nodes:
            return np.zeros((0, 3))
        return self.graph.poses()

    def pose_of(self, odom_pose: Sequence[float] | FloatArray) -> FloatArray:
        """Map pose of the robot at ``odom_pose`` with the current correction."""
        return se2_compose(self._map_to_odom, np.asarray(odom_pose, float))

    @property
    def submaps(self) -> LoopCloser:
        """The loop closer (its ``submaps`` group the nodes)."""
        return self._loops

    # --- serialization support (navstack.mapping.slam_io) ----------------------------
    def state(self) -> dict[str, Any]:
        """What besides nodes and graph a saved session needs to continue seamlessly."""
        last = self._last_accepted_odom
        return {"running": list(self._running), "map_to_odom": self._map_to_odom.copy(),
                "last_odom": np.full(3, np.nan) if last is None else last.copy(),
                "last_stamp": self._last_accepted_stamp,
                "odometry_noise": self._odometry_noise.samples()}

    def restore_state(self, running: list[int], map_to_odom: FloatArray, last_odom: FloatArray,
                      last_stamp: float, start_pose: FloatArray | None = None,
                      odometry_noise: FloatArray | None = None) -> None:
        """Inverse of :meth:`state`.  With ``start_pose`` the next scan starts a new
        odometry frame at that map pose and is matched against the saved map there."""
        if odometry_noise is not None:
            self._odometry_noise.restore(odometry_noise)
        if self.params.mode == "localization":
            self.frozen_nodes = len(self.nodes)
        self._refresh_poses(full=True)
        n = len(self.nodes)
        self._covs = np.zeros((n, 3, 3))
        for node in self.nodes:
            self._loops.submaps.add(node.node_id)
        if n:
            self._last_node_stamp = self.nodes[-1].stamp
            self._last_placed = n - 1
        if start_pose is None:
            self._running = list(running)
            self._map_to_odom = np.asarray(map_to_odom, float).copy()
            self._last_accepted_odom = None if np.isnan(last_odom).any() else last_odom.copy()
            self._last_accepted_stamp = float(last_stamp)
            return
        self._start_override = np.asarray(start_pose, float).copy()
        self._running = []
        self._last_accepted_odom = None
        self._last_accepted_stamp = -math.inf
        self._restart = True

    # --- scan points -----------------------------------------------------------------
    def scan_points(self, ranges: NDArray[np.floating]) -> FloatArray:
        """Beam endpoints (base frame) usable for matching: real returns within range."""
        r = np.asarray(ranges, float)
        usable = min(self.laser.range_max, self.params.max_laser_range)
        lo = max(self.laser.range_min, self.params.min_laser_range)
        ok = np.isfinite(r) & (r >= lo) & (r < usable) & (r < self.laser.range_max)
        a = self.laser.angles[ok]
        pts = np.column_stack([r[ok] * np.cos(a), r[ok] * np.sin(a)])
        mount = self.laser.mount
        if np.any(mount != 0.0):
            c, s = math.cos(mount[2]), math.sin(mount[2])
            pts = pts @ np.array([[c, s], [-s, c]]) + mount[:2]
        return pts

    def _world_points(self, index: int) -> FloatArray:
        node = self.nodes[index]
        pose = self._poses[index]
        cached = self._world_cache.get(index)
        if cached is not None and np.array_equal(cached[0], pose):
            return cached[1]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        world = node.points @ np.array([[c, s], [-s, c]]) + pose[:2]
        self._world_cache[index] = (pose.copy(), world)
        return world

    def _world_features(self, ids: Sequence[int]) -> tuple[FloatArray, FloatArray,
                                                           NDArray[np.bool_]]:
        pts, nrm, msk = [], [], []
        for i in ids:
            pts.append(self._world_points(i))
            c, s = math.cos(self._poses[i, 2]), math.sin(self._poses[i, 2])
            nrm.append(self.nodes[i].normals @ np.array([[c, s], [-s, c]]))
            msk.append(self.nodes[i].line_like)
        return np.vstack(pts), np.vstack(nrm), np.concatenate(msk)

    # --- gating ----------------------------------------------------------------------
    def _should_process(self, odom: FloatArray | None, stamp: float) -> bool:
        p = self.params
        self._scan_count += 1
        if self._last_accepted_odom is None or odom is None:
            return True
        if p.throttle_scans > 1 and self._scan_count % p.throttle_scans != 0:
            return False
        if 0.0 <= stamp - self._last_accepted_stamp < p.minimum_time_interval:
            return False  # (logs can step back in time: such a scan is not throttled)
        delta = se2_between(self._last_accepted_odom, odom)
        moved = math.hypot(delta[0], delta[1])
        return not (moved < p.minimum_travel_distance
                    and abs(delta[2]) < p.minimum_travel_heading)

    # --- main entry ------------------------------------------------------------------
    def process_scan(self, ranges: NDArray[np.floating],
                     odom_pose: Sequence[float] | FloatArray | None, stamp: float,
                     odom_gap: bool = False) -> bool:
        """Add a scan taken at ``odom_pose`` (odom frame); True when it became a node.

        ``odom_pose`` ``None`` means the scan has no odometry; ``odom_gap`` that the
        odometry *since the previous scan* is missing (its pose is not continuous with
        the earlier ones).  Either way the scan is placed by a wide search."""
        self.stats.scans_received += 1
        odom = None if odom_pose is None else np.asarray(odom_pose, float)
        check = odometry_verdict(self.params, odom, stamp, odom_gap,
                                 None if self._restart else self._last_accepted_odom,
                                 self._last_accepted_stamp)
        if not check.suspect and not self._should_process(odom, stamp):
            self._skipped_scan(ranges, odom)
            return False
        if odom is None and not odom_gap and self.nodes and self.params.mode == "mapping" \
                and not self._restart:
            self._register_without_odometry(ranges, float(stamp), check)
            return False
        if check.suspect:
            self._scan_count += 1
        points = self.scan_points(ranges)
        if self._start_override is not None and odom is not None:
            self._map_to_odom = se2_compose(self._start_override, se2_inverse(odom))
            self._start_override = None
        if self.params.mode == "localization":
            if odom is not None:
                self._localize(points, odom)
                self._last_accepted_odom, self._last_accepted_stamp = odom, stamp
            return False
        self.stats.scans_processed += 1
        normals, line_like = line_normals(points)
        node = ScanNode(len(self.nodes), np.full(3, np.nan) if odom is None else odom,
                        float(stamp), np.asarray(ranges, np.float32).copy(), points,
                        normals, line_like)
        if not self.nodes:
            start = self._start_pose(odom if odom is not None else np.zeros(3))
            self._append_node(node, start)
            self.graph.update()
        else:
            self._add_linked_node(node, odom, check)
        self._after_node(node.node_id)
        if self.params.do_loop_closing and self.nodes:
            self._try_loop_closures(node.node_id)
        if node.node_id not in self._unplaced:
            self._running.append(node.node_id)
        self._trim_running()
        if odom is not None:
            self._last_accepted_odom, self._last_accepted_stamp = odom, stamp
            self._map_to_odom = se2_compose(self._poses[node.node_id], se2_inverse(odom))
        self._last_node_stamp = float(stamp)
        self.last_scan = (node.node_id, np.zeros(3))
        return True

    def _skipped_scan(self, ranges: NDArray[np.floating], odom: FloatArray | None) -> None:
        """A scan that does not become a node: its pose relative to the last node, by a
        local match against the running buffer when ``match_skipped_scans`` (else by
        odometry).  Never added to the graph.  The match and the odometry since the last
        node are fused by their information, so a match that is free along a corridor
        or in an open space keeps the odometry's position there."""
        if not self.nodes or odom is None:
            self.last_scan = None
            return
        last = self.nodes[-1].node_id
        pose = self._predicted(odom)
        p = self.params
        if p.match_skipped_scans and p.mode == "mapping" and self._running:
            ref, nrm, msk, grid = self._local_map(self._running)
            match = self.match_points(ref, nrm, msk, self.scan_points(ranges), pose,
                                      grid=grid)
            if match is not None and match.response >= p.link_match_minimum_response_fine:
                odo_cov = self._odometry_noise.covariance(
                    se2_between(self._poses[last], pose))
                pose = fuse(pose, odo_cov, match.pose,
                             tangent_covariance(match.covariance, match.pose[2]))
        self.last_scan = (last, se2_between(self._poses[last], pose))

    def _register_without_odometry(self, ranges: NDArray[np.floating], stamp: float,
                                   check: OdometryCheck) -> None:
        """A scan that has no odometry while the odometry stream goes on (the next scan's
        odometry still continues from the last node): it tells the graph nothing the
        stream does not, so it is only registered -- the local match around the last
        motion repeated, else the wide search -- for its pose, and never becomes a node
        (a wrong fit cannot bend the map)."""
        p = self.params
        points = self.scan_points(ranges)
        last = self.nodes[-1].node_id
        guess = self._motion_prediction(stamp)
        pose = guess
        self.stats.odometry_events.append((self.stats.scans_received - 1, check.reason))
        if self._running and points.shape[0] >= 10:
            ref, nrm, msk, grid = self._local_map(self._running)
            match = self.match_points(ref, nrm, msk, points, guess, grid=grid,
                                      covariance=False)
            if match is None or match.response < 0.9 * self.typical_response():
                radius = check.search_radius(p, False, stamp - self.nodes[last].stamp,
                                             self._seen_speed(), self._seen_step(),
                                             distance(guess, self._poses[last]))
                wide = wide_link(self, points, guess, radius, self._running)
                if wide is not None and (match is None or wide.response > match.response):
                    self.stats.wide_recoveries += 1
                    self.stats.recovered_scans.append(self.stats.scans_received - 1)
                    match = wide
            if match is not None and match.response >= p.link_match_minimum_response_fine:
                pose = match.pose
        self.last_scan = (last, se2_between(self._poses[last], pose))

    def register(self, ranges: NDArray[np.floating], guess: FloatArray | Sequence[FloatArray]
                 ) -> FloatArray | None:
        """Pose of a scan near ``guess`` against the nodes around it (a local match; no
        node, no edge), or ``None`` if it does not fit.  With several guesses (a list of
        poses) each is matched against the nodes around the first and the best fit wins
        (the scan lies somewhere along a path and one window does not cover it)."""
        p = self.params
        guesses = ([np.asarray(guess, float)] if isinstance(guess, np.ndarray)
                   and guess.ndim == 1 else [np.asarray(g, float) for g in guess])
        points = self.scan_points(ranges)
        near = self._nearest_nodes(guesses[0], p.scan_buffer_size,
                                   p.scan_buffer_maximum_scan_distance)
        if not near or points.shape[0] < 10:
            return None
        ref, nrm, msk, grid = self._local_map(near)
        best: MatchResult | None = None
        for g in guesses:
            match = self.match_points(ref, nrm, msk, points, g, grid=grid, covariance=False)
            if match is not None and (best is None or match.response > best.response):
                best = match
        if best is None or best.response < p.link_match_minimum_response_fine:
            return None
        return best.pose

    def _seen_speed(self) -> float:
        """The robot's top speed so far (90th percentile: log clocks jitter), 0 before
        :data:`SEEN_MOTION_MINIMUM_SAMPLES` speeds were measured."""
        return float(np.percentile(self._speeds, 90)) \
            if len(self._speeds) >= SEEN_MOTION_MINIMUM_SAMPLES else 0.0

    def _seen_step(self) -> float:
        """The robot's longest step between placed scans so far (90th percentile), 0
        before :data:`SEEN_MOTION_MINIMUM_SAMPLES` steps were measured: the reach of a
        step without odometry when the clock cannot tell
        (:meth:`OdometryCheck.search_radius`)."""
        return float(np.percentile(self._steps, 90)) \
            if len(self._steps) >= SEEN_MOTION_MINIMUM_SAMPLES else 0.0

    def _start_pose(self, odom: FloatArray) -> FloatArray:
        start = self.params.map_start_pose
        if start is not None:
            return np.asarray(start[:3], float)
        return odom.copy()

    def _predicted(self, odom: FloatArray) -> FloatArray:
        """Predicted map pose: the current ``map -> odom`` applied to the odometry pose
        (equal to the last node composed with the odometry increment since it)."""
        return se2_compose(self._map_to_odom, odom)

    def _nearest_nodes(self, pose: FloatArray, count: int, radius: float) -> list[int]:
        poses = self._poses
        dist = np.hypot(poses[:, 0] - pose[0], poses[:, 1] - pose[1])
        near = np.flatnonzero(dist <= radius)
        return [int(i) for i in near[np.argsort(dist[near])][:count]]

    # --- matching --------------------------------------------------------------------
    def match_points(self, reference: FloatArray, normals: FloatArray,
                     line_like: NDArray[np.bool_], points: FloatArray, guess: FloatArray,
                     window: SearchWindow | None = None, grid: LikelihoodGrid | None = None,
                     covariance: bool = True) -> MatchResult | None:
        """Correlative match of ``points`` (robot frame) against ``reference`` points
        (any frame) around ``guess`` in that frame, polished by point-to-line ICP; the
        local search of ``correlation_search_space_*`` unless ``window`` is given.
        ``grid`` is the reference's likelihood grid if already built; without
        ``covariance`` the result's covariance is the floor only (skipped scans)."""
        win = window or self._window
        p = self.params
        if reference.shape[0] == 0 or points.shape[0] < 10:
            return None
        if grid is None:
            c, s = math.cos(guess[2]), math.sin(guess[2])
            query = points @ np.array([[c, s], [-s, c]]) + guess[:2]
            reach = float(np.hypot(points[:, 0], points[:, 1]).max())
            # rotating by the angular window sweeps far points by reach * angle
            margin = (0.5 * win.dimension + reach * min(win.coarse_angle_offset, math.pi)
                      + 4 * p.correlation_search_space_smear_deviation)
            grid = LikelihoodGrid.around(reference, query, margin,
                                         p.correlation_search_space_resolution,
                                         p.correlation_search_space_smear_deviation)
        # the correlative search scores at most one point per 2 x 2 cells: near returns
        # of a dense lidar would otherwise dominate the score and the cost
        sparse = voxel_filter(points, 2.0 * p.correlation_search_space_resolution)
        match = match_scan(grid, sparse, guess, win)
        pose = match.pose
        if p.use_point_to_line_refinement:
            refined, used = refine_point_to_line(reference, normals, line_like, points, pose)
            limit = 2.0 * p.correlation_search_space_resolution
            if used and math.hypot(*(refined[:2] - pose[:2])) <= limit:
                pose = refined
        unit = self.match_unit()
        cov = (self._link_covariance(grid, sparse, match, win) if covariance
               else np.diag(unit * unit))
        return MatchResult(pose=pose, response=match.response, hessian=match.hessian,
                           covariance=cov)

    def _local_map(self, ids: Sequence[int]) -> tuple[FloatArray, FloatArray,
                                                      NDArray[np.bool_],
                                                      LikelihoodGrid | None]:
        """Points, normals, line mask and likelihood grid of nodes ``ids`` at their
        current poses, the grid covering all of them; the last one is kept, so the scans
        between two nodes (and the next node's link) reuse it.  No grid when the nodes
        hold no point (open space beyond the lidar's range): nothing to match against,
        and :meth:`match_points` says so."""
        key = (tuple(ids), self._poses[list(ids)].tobytes())
        if self._local_cache is not None and self._local_cache[0] == key:
            return self._local_cache[1]
        p = self.params
        ref, nrm, msk = self._world_features(ids)
        if ref.shape[0] == 0:
            empty = (ref, nrm, msk, None)
            self._local_cache = (key, empty)
            return empty
        res = p.correlation_search_space_resolution
        reach = 3.0 * p.correlation_search_space_smear_deviation + 5 * res
        lo = ref.min(axis=0) - reach
        hi = ref.max(axis=0) + reach
        grid = LikelihoodGrid(ref, res, p.correlation_search_space_smear_deviation,
                              (lo[0], lo[1], hi[0], hi[1]))
        value = (ref, nrm, msk, grid)
        self._local_cache = (key, value)
        return value

    def _static_mask(self, reference: FloatArray, ranges: NDArray[np.floating],
                     guess: FloatArray, step: FloatArray) -> NDArray[np.bool_] | None:
        """False for ``reference`` points (world frame) the new scan ``ranges`` sees
        through from ``guess`` (moved objects, e.g. a person walking ahead), see
        :mod:`navstack.mapping.free_space`; ``None`` when ``dynamic_point_margin`` is 0.

        The guess rests on the odometry ``step`` since the last node: the margin grows
        by twice that step's expected error (:class:`OdometryNoise`'s factors, learned
        from the matches: translation ``k_lin * distance``, heading
        ``k_ang * (turn + 0.2 distance)`` times the point's range).  With a fixed margin
        a poor odometry step made whole walls look seen through (Intel with every second
        scan's odometry missing: 30-80 points of each match, 2-5 m away; ATE 0.118 m
        instead of 0.051 m without the test)."""
        margin = self.params.dynamic_point_margin
        if margin <= 0.0 or reference.shape[0] == 0:
            return None
        k_lin, k_ang = self._odometry_noise.factors()
        dist = math.hypot(float(step[0]), float(step[1]))
        heading = k_ang * (abs(float(step[2])) + 0.2 * dist)
        laser = self.laser
        return ~seen_through(ranges, laser.angles, laser.range_min,
                             min(laser.range_max, self.params.max_laser_range),
                             se2_compose(guess, laser.mount), reference,
                             margin + 2.0 * k_lin * dist,
                             range_fraction=0.02 + 2.0 * heading)

    def _same_lattice(self, grid: LikelihoodGrid, reference: FloatArray
                      ) -> LikelihoodGrid | None:
        """Likelihood grid of ``reference`` on ``grid``'s lattice and extent (the
        running buffer's grid with the seen-through points left out: the same cells, so
        the responses stay comparable with the other links')."""
        if reference.shape[0] == 0:
            return None
        p = self.params
        res = grid.resolution
        h, w = grid.fine.shape
        x0, y0 = float(grid.origin[0]), float(grid.origin[1])
        return LikelihoodGrid(reference, res, p.correlation_search_space_smear_deviation,
                              (x0, y0, x0 + (w - 1.5) * res, y0 + (h - 1.5) * res),
                              grid.block)

    def _link_window(self, step: FloatArray) -> SearchWindow | None:
        """The link's search window for an odometry ``step`` since the last node: the
        usual one (``coarse_search_angle_offset``, ``correlation_search_space_dimension``),
        or wider when the odometry's own uncertainty over this step (:class:`OdometryNoise`,
        learned from the matches, 3 sigmas) reaches beyond it -- a turn with poor
        odometry, or a step spread over two scans when one scan between them lost its
        odometry.  ``None``: the usual."""
        sigma = math.sqrt(float(self._odometry_noise.covariance(step)[2, 2]))
        half = LINK_WINDOW_SIGMAS * sigma
        # and wider in translation, up to the wide search's smallest radius, when the
        # odometry's position uncertainty over the step does (CSAIL with every second
        # scan's odometry missing: 2 m steps with odometry 0.3-0.8 m off; ATE 0.22 ->
        # 0.12 m)
        width = min(2.0 * LINK_WINDOW_SIGMAS * math.sqrt(float(
            self._odometry_noise.covariance(step)[0, 0])),
            2.0 * self.params.recovery_search_minimum_distance)
        if half <= self._window.coarse_angle_offset and width <= self._window.dimension:
            return None
        usual = self._window
        return replace(usual, coarse_angle_offset=min(math.pi,
                                                      max(half, usual.coarse_angle_offset)),
                       dimension=max(width, usual.dimension))

    def match_unit(self) -> FloatArray:
        """Standard deviations of a perfectly constrained match (x, y, theta): one
        search cell and two fine angle steps."""
        p = self.params
        return np.array([p.correlation_search_space_resolution] * 2
                        + [2.0 * p.fine_search_angle_offset])

    def _link_covariance(self, grid: LikelihoodGrid, points: FloatArray,
                         match: MatchResult, window: SearchWindow) -> FloatArray:
        """Covariance of a match: the spread of its response surface
        (:func:`~navstack.mapping.scan_matcher.response_covariance`, Karto's) plus a floor
        of one search cell and two fine angle steps (one standard deviation).

        The Gauss-Newton covariance of the smeared fit is far below the matcher's real
        accuracy (on Intel and ACES its NEES against the reference was 5x too high) and
        it misses flat directions that a door frame makes look curved; the response
        surface sees a corridor or an open hall as what it is, so that the odometry and
        the loop closures decide the directions a scan leaves open."""
        unit = self.match_unit()
        cov = response_covariance(grid, points, match.pose, window) + np.diag(unit * unit)
        ratio = self.params.link_match_coupled_variance_ratio
        if ratio > 0.0 and match.hessian is not None:
            coupled = coupled_covariance(grid, points, match.pose, match.hessian, unit, ratio)
            if coupled is not None:
                cov = cov + coupled
        return cov

    # --- nodes and edges --------------------------------------------------------------
    def _append_node(self, node: ScanNode, pose: FloatArray) -> None:
        self.nodes.append(node)
        self.graph.add_node(node.node_id, pose)
        self._poses = np.vstack((self._poses, np.asarray(pose, float)[None]))
        self._covs = np.concatenate((self._covs, np.zeros((1, 3, 3))))
        self._loops.submaps.add(node.node_id)

    def _add_linked_node(self, node: ScanNode, odom: FloatArray | None,
                         check: OdometryCheck) -> None:
        p = self.params
        restarting = self._restart
        prev_id = self.nodes[-1].node_id
        placed_id = self._last_placed
        # no usable prediction: no odometry, a gap, or the previous scan could not be
        # placed (its odometry frame is unknown) -> predict by the last motion, search wide
        # (a previous scan that had no odometry at all leaves the odometry stream intact:
        # this scan's odometry still continues from the last node that had some)
        prev_cut = prev_id in self._unplaced and bool(np.isfinite(self.nodes[prev_id].odom).all())
        missing = check.missing or odom is None or prev_cut
        guess = (self._predicted(odom) if odom is not None and not missing
                 else self._motion_prediction(node.stamp))
        reference = (self._nearest_nodes(guess, p.scan_buffer_size,
                                         p.scan_buffer_maximum_scan_distance)
                     if restarting else list(self._running))
        match: MatchResult | None = None
        window = None if missing else self._link_window(
            se2_between(self._poses[prev_id], guess))
        # too few returns to constrain a match (open space beyond a short lidar's range):
        # with trusted odometry the scan is placed by it, as an odometry link
        sparse = (node.points.shape[0] < p.link_match_minimum_points
                  and not (missing or restarting or check.suspect))
        if sparse:
            self.stats.sparse_nodes += 1
        if p.use_scan_matching and reference and not sparse:
            ref, nrm, msk, local = self._local_map(reference)
            grid: LikelihoodGrid | None = local
            if not (missing or restarting or check.suspect):
                # only around a trusted prediction: from a wrong guess the scan would
                # 'see through' the walls it is to be matched to
                keep = self._static_mask(ref, node.ranges, guess, se2_between(
                    self._poses[prev_id], guess))
                if (keep is not None and local is not None and not keep.all()
                        and keep.mean() >= 0.9):
                    ref, nrm, msk = ref[keep], nrm[keep], msk[keep]
                    grid = self._same_lattice(local, ref)
            points = node.points if restarting or missing else self._covered(
                node.points, guess, reference)
            match = self.match_points(ref, nrm, msk, points, guess, window=window,
                                      grid=grid)
        failed = match is None or match.response < p.link_match_minimum_response_fine
        typical = self.typical_response()
        radius = check.search_radius(p, restarting, node.stamp - self.nodes[placed_id].stamp,
                                     self._seen_speed(), self._seen_step(),
                                     distance(guess, self._poses[placed_id]))
        if p.use_scan_matching and not sparse and (check.suspect or restarting or failed
                                                   or missing):
            query = node.points
            if not check.missing and odom is not None and prev_cut:
                query = self._with_floating(node.points, odom)
            if missing:
                # no odometry over the step: always search as far as the robot could
                # have moved (a strong local fit around a guessed motion is often a
                # corridor's alias), then choose (:func:`~navstack.mapping.slam_links.gap_choice`)
                full = check.search_radius(p, restarting, node.stamp
                                           - self.nodes[placed_id].stamp, self._seen_speed())
                wide, ambiguous, radius = self._gap_search(query, guess, radius, full,
                                                           reference, typical)
                chosen = gap_choice(match, wide, ambiguous, typical)
                if ambiguous and chosen is not None:
                    self.stats.ambiguous_scans.append(self.stats.scans_received - 1)
            else:
                wide = wide_link(self, query, guess, radius, reference)
                # the local match around the odometry loses only to a fit it would
                # itself count as failed against: below recovery_response_ratio times it
                chosen = wide if wide is not None and (
                    failed or match is None
                    or match.response < p.recovery_response_ratio * wide.response) else match
            if chosen is not None and chosen is wide and (
                    match is None or math.hypot(*(wide.pose[:2] - match.pose[:2])) > 0.05):
                self.stats.wide_recoveries += 1
                self.stats.recovered_scans.append(self.stats.scans_received - 1)
            match = chosen
        if check.suspect:
            self.stats.odometry_events.append((self.stats.scans_received - 1, check.reason))
        matched = match is not None and match.response >= p.link_match_minimum_response_fine
        anchor = reference[0] if restarting and reference else (
            placed_id if missing else prev_id)
        if match is not None and matched:
            pose = match.pose
            ratio = p.link_match_weak_direction_ratio
            if ratio > 0.0 and not (missing or restarting or check.suspect) and degenerate(
                    match.covariance, self.match_unit(), ratio):
                # a degenerate match: its flat directions are noise, the odometry's
                # prediction decides there (information-weighted, as for skipped scans)
                pose = fuse(guess, self._odometry_noise.covariance(
                    se2_between(self._poses[prev_id], guess)), pose,
                    tangent_covariance(match.covariance, pose[2]))
            cov = tangent_covariance(match.covariance, pose[2])
            if not check.suspect and not missing:
                self._responses = [*self._responses, match.response][-20:]
        else:
            if p.use_scan_matching and not sparse:
                self.stats.match_failures += 1
            pose = guess
            if missing:
                # not placed: tied loosely to the last placed node, kept out of the
                # running buffer until the odometry to a later placed scan pins it
                self.stats.unlinked_nodes += 1
                self._unplaced.add(node.node_id)
                cov = np.diag([radius**2, radius**2, math.pi**2])
            else:
                cov = self._odometry_noise.covariance(se2_between(self._poses[prev_id], guess))
                if restarting:  # an unverified restart pose: tie it loosely
                    cov = cov + np.diag([0.25, 0.25, 0.1])
        kernel = p.link_match_robust_kernel
        if matched and missing:
            # placed without odometry: the fit may be an alias, so the link is a loop
            # closure in all but name -- robust, so later closures can cut it, and as
            # uncertain as a recovery search's cell, so the loop search looks wide enough
            kernel = p.loop_closure_robust_kernel
            cell = max(p.loop_search_space_resolution, radius / 40.0)
            cov = cov + np.diag([cell * cell, cell * cell, math.radians(1.0) ** 2])
        self._append_node(node, pose)
        self._gap_before[node.node_id] = check.missing or odom is None
        self.graph.add_edge(anchor, node.node_id, se2_between(self._poses[anchor], pose),
                            np.linalg.inv(cov), robust_kernel=kernel,
                            kernel=p.loop_closure_robust_kernel_type)
        prev_odom = self.nodes[prev_id].odom
        if (prev_id in self._unplaced and not check.missing and odom is not None
                and np.isfinite(prev_odom).all()):
            # the odometry from the unplaced scan to this one: places it once this one is
            step = se2_between(prev_odom, odom)
            self.graph.add_edge(prev_id, node.node_id, step,
                                np.linalg.inv(self._odometry_noise.covariance(step)))
            if matched:
                self._unplaced.discard(prev_id)
        if node.node_id not in self._unplaced:
            dt = node.stamp - self.nodes[placed_id].stamp
            if matched and not missing:
                moved = math.hypot(float(pose[0] - self._poses[placed_id, 0]),
                                   float(pose[1] - self._poses[placed_id, 1]))
                self._steps = [*self._steps, moved][-200:]
                if dt > 0.0:
                    self._speeds = [*self._speeds, moved / dt][-200:]
            self._last_placed = node.node_id
        if (p.use_odometry_edges and matched and not restarting and not check.suspect
                and odom is not None and np.isfinite(prev_odom).all()):
            weak_match = degenerate(cov, self.match_unit())
            # the scale is learned from well-conditioned matches only: along a corridor
            # or across an open space the match is what is uncertain (its pull-back along
            # walls that run out of range taught a wrong scale: simulated campus ATE 0.059
            # -> 0.024 m); the noise from every match, as before, unless
            # odometry_noise_from_degenerate_matches is off (there the disagreement is the
            # match's error: a short-range lidar's sparse scans made good wheel odometry
            # look 5x worse than it is)
            if p.odometry_noise_from_degenerate_matches or not weak_match:
                self._odometry_noise.observe(se2_between(prev_odom, odom),
                                             se2_between(self._poses[prev_id], pose),
                                             scale=not weak_match)
            step = se2_between(prev_odom, odom)
            if p.odometry_scale_correction:
                step = self._odometry_noise.calibrated_step(step)
            odo_cov = self._odometry_noise.covariance(step)
            if self._odometry_noise.calibrated and (p.odometry_edges_on_every_link or (
                    weak_match and float(np.max(np.linalg.eigvals(
                        cov @ np.linalg.inv(odo_cov)).real)) >= 0.1)):
                # the odometry as its own constraint where the scan match is degenerate
                # (along a corridor, in an open hall: Zhang, Kaess & Singh, ICRA 2016)
                # and the odometry carries at least a tenth of the match's information
                # in the weak direction.  On a well-conditioned match it would only
                # bias the result with the odometry's (often heavy-tailed) error.  Only
                # the weak directions take the odometry's information (Zhang et al.'s
                # solution remapping): the scan fixes the others -- in a corridor the
                # heading and the lateral position -- far better than wheels do.
                odo_info = np.asarray(np.linalg.inv(odo_cov), float)
                if p.odometry_edge_weak_directions:
                    odo_info = weak_part(odo_info, cov, self.match_unit())
                self.graph.add_edge(prev_id, node.node_id, step, odo_info,
                                    robust_kernel=p.odometry_edge_robust_kernel,
                                    kernel="cauchy")
                self.stats.odometry_edges += 1
        self.graph.update()
        if restarting:
            self._running = []
            self._restart = False

    def _gap_search(self, query: FloatArray, guess: FloatArray, radius: float, full: float,
                    reference: Sequence[int], typical: float
                    ) -> tuple[MatchResult | None, bool, float]:
        """The wide search of a scan with no odometry over its step
        (:func:`~navstack.mapping.recovery.predicted_link`) within ``radius``, and
        within ``full`` -- the reach the clock alone allows, larger when ``radius``
        came from the seen step (:meth:`OdometryCheck.search_radius`) -- when nothing
        fits within ``radius`` or only an ambiguous fit below ``GAP_STRONG_RESPONSE``
        times the ``typical`` response: the seen step assumes one step, scans may have
        been lost (the 80 degree turn cut out of CSAIL: a weak ambiguous fit 1.5 m off
        at the wrong heading).  The wider search's answer replaces it unless that is
        ambiguous too (then the nearer one is the likelier: CSAIL's corridors, every
        second interval without odometry).  Returns the fit, whether it is ambiguous and
        the radius it came from."""
        wide, ambiguous = predicted_link(self, query, guess, radius, reference)
        if radius < full and (wide is None or (
                ambiguous and wide.response < GAP_STRONG_RESPONSE * typical)):
            far, far_ambiguous = predicted_link(self, query, guess, full, reference)
            if far is None or not far_ambiguous:
                return far, False, full
        return wide, ambiguous, radius

    def _with_floating(self, points: FloatArray, odom: FloatArray) -> FloatArray:
        """``points`` plus the scans of the unplaced nodes just before this scan, drawn
        in its frame by the odometry between them (a wider view of the same place: one
        scan alone is often ambiguous, two or three seldom are)."""
        parts = [points]
        k = len(self.nodes) - 1
        while k >= 0 and k in self._unplaced and len(parts) < 4:
            o = self.nodes[k].odom
            if not np.isfinite(o).all():
                break
            rel = se2_between(odom, o)
            c, s = math.cos(rel[2]), math.sin(rel[2])
            parts.append(self.nodes[k].points @ np.array([[c, s], [-s, c]]) + rel[:2])
            if self._gap_before.get(k, True):
                break  # its own odometry is not continuous with the one before it
            k -= 1
        return np.vstack(parts)

    def typical_response(self) -> float:
        """Median response of the recent ordinary links (1.0 before there are five)."""
        return float(np.median(self._responses)) if len(self._responses) >= 5 else 1.0

    def _motion_prediction(self, stamp: float) -> FloatArray:
        """Pose of a scan without usable odometry: the last placed node moved on by its
        own last motion -- constant velocity: the translation scaled by the elapsed time
        when the clock tells it (at most :data:`PREDICTION_MAXIMUM_SCALE` times), the turn
        as it was.

        Measured on the reference trajectories of Intel / ACES / CSAIL (each step
        predicted from the one before): scaling the turn too, up to 3 times, put the
        worst predictions 112 / 156 / 88 degrees and 2.8 / 3.0 / 1.2 m off (a robot
        that turned in place, then drove on for longer); with the translation scaled at
        most 1.5 times and the turn kept, 56 / 96 / 88 degrees and 1.4 / 1.4 / 1.2 m
        (median 6 / 8 / 10 degrees, 0.17 / 0.16 / 0.21 m)."""
        b = self._last_placed
        placed = [i for i in self._running if i != b]
        if not placed:
            return self._poses[b].copy()
        a = placed[-1]
        step = se2_between(self._poses[a], self._poses[b])
        dt_ab = self.nodes[b].stamp - self.nodes[a].stamp
        dt = stamp - self.nodes[b].stamp
        if dt_ab > 0.0 and dt > 0.0:
            f = min(dt / dt_ab, PREDICTION_MAXIMUM_SCALE)
            step = np.array([step[0] * f, step[1] * f, step[2]])
        return se2_compose(self._poses[b], step)

    def _after_node(self, node_id: int) -> None:
        """Refresh the poses ISAM2 moved near the new node and store its marginal."""
        self._refresh_poses(ids=[*self._running, node_id])
        self._covs[node_id] = self.graph.marginal_covariance(node_id)

    def refresh_poses(self, ids: Sequence[int]) -> None:
        """Bring the kept poses of nodes ``ids`` up to the graph's estimate."""
        self._refresh_poses(ids=ids)

    def _refresh_poses(self, ids: Sequence[int] | None = None, full: bool = False) -> None:
        if full or ids is None or self._poses.shape[0] != len(self.nodes):
            self._poses = self.graph.poses() if self.nodes else np.zeros((0, 3))
            return
        for i in ids:
            self._poses[i] = self.graph.pose(i)

    def _covered(self, points: FloatArray, guess: FloatArray,
                 reference_ids: Sequence[int]) -> FloatArray:
        """The scan points (base frame) the reference scans could have seen: within
        ``usable range - link_match_coverage_margin`` of at least one reference scan's
        laser, placed at ``guess``.

        With a short-range laser, walls that run on out of range (a corridor longer than
        the LDS's 3.5 m) end in every scan at the range limit, not at a feature.  The new
        scan, taken ``minimum_travel_distance`` further on, reaches that much further
        along them; its leading points fall where no reference scan looked, score
        nothing, and the correlative search prefers the shift that lays them back over
        known wall -- the pose is pulled back towards the previous scans by a few cells
        at every node (office corridor, TurtleBot3: 4-8 cm per node, 0.17 m in 5 m).
        Leaving those points out of the match removes the pull; points the references
        did see keep constraining every direction.  ``0`` keeps every point (Karto)."""
        margin = self.params.link_match_coverage_margin
        if margin <= 0.0 or len(reference_ids) == 0 or points.shape[0] == 0:
            return points
        usable = min(self.laser.range_max, self.params.max_laser_range) - margin
        poses = self._poses
        c, s = math.cos(guess[2]), math.sin(guess[2])
        world = points @ np.array([[c, s], [-s, c]]) + guess[:2]
        near = np.zeros(points.shape[0], dtype=bool)
        for i in reference_ids:
            origin = se2_compose(poses[i], self.laser.mount)
            near |= np.hypot(world[:, 0] - origin[0], world[:, 1] - origin[1]) <= usable
        return points[near]

    def _trim_running(self) -> None:
        p = self.params
        self._running = self._running[-p.scan_buffer_size:]
        if len(self._running) > 1:
            here = self._poses[self._running[-1], :2]
            self._running = [i for i in self._running
                             if np.hypot(*(self._poses[i, :2] - here))
                             <= p.scan_buffer_maximum_scan_distance]

    # --- loop closure ----------------------------------------------------------------
    def _try_loop_closures(self, node_id: int) -> None:
        p = self.params
        candidates = self._loops.candidates(node_id, self._poses, self._covs,
                                            self._covs[node_id])
        found = []
        for candidate in candidates:
            closure = self._loops.match(node_id, candidate, self._poses)
            if closure is not None:
                found.append(closure)
        closures = self._loops.confirm(found, node_id, self._poses)
        if not closures:
            return
        before = self._poses[node_id].copy()
        edges = [self.graph.add_edge(c.anchor, c.node, c.measurement,
                                     np.linalg.inv(c.covariance),
                                     robust_kernel=p.loop_closure_robust_kernel,
                                     kernel=p.loop_closure_robust_kernel_type)
                 for c in closures]
        self._closure_edges.extend(edges)
        self.graph.update()
        self.stats.loop_closures += len(edges)
        batch = math.hypot(*(self.graph.pose(node_id)[:2] - before[:2])) \
            > p.loop_closure_batch_distance
        if batch:
            self._optimize()
            self.graph.update()
            self.stats.batch_optimizations += 1
        # the running buffer and this node now; the rest when a batch ran or every
        # tenth closure (the loop search tolerates centimetres of stale positions and
        # refreshes the members of a submap before drawing it)
        self._closure_events += 1
        if batch or self._closure_events % 10 == 0:
            self._refresh_poses(full=True)
        else:
            self._refresh_poses(ids=[*self._running, node_id])
        self._covs[node_id] = self.graph.marginal_covariance(node_id)

    def _optimize(self) -> float:
        """Batch Levenberg-Marquardt, then the outlier check: a loop closure whose
        residual at the optimum still exceeds ``loop_closure_maximum_chi2`` (its robust
        kernel already let it go) is removed and the graph optimised again.  Checked
        only at a batch optimum: right after a closure lands, ISAM2 has not yet spread
        the correction, and a good closure that undoes a bad link looks like an
        outlier there."""
        cost = self.graph.optimize()
        p = self.params
        bad = [k for k in self._closure_edges
               if self.graph.edge_chi2(k) > p.loop_closure_maximum_chi2]
        if bad:
            for k in bad:
                self.graph.remove_edge(k)
            self._closure_edges = [k for k in self._closure_edges if k not in set(bad)]
            self.stats.loop_rejected_outliers += len(bad)
            self.stats.loop_closures -= len(bad)
            cost = self.graph.optimize()
        return cost

    # --- localization mode -----------------------------------------------------------
    def _localize(self, points: FloatArray, odom: FloatArray) -> None:
        """Match against the loaded graph's scans near the predicted pose; move map->odom."""
        p = self.params
        guess = self.pose_of(odom)
        near = self._nearest_nodes(guess, p.scan_buffer_size,
                                   p.scan_buffer_maximum_scan_distance)
        if not near:
            self.stats.match_failures += 1
            return
        match = self.match_points(*self._world_features(near), points, guess)
        if match is None or match.response < p.link_match_minimum_response_fine:
            self.stats.match_failures += 1
            return
        self.stats.scans_processed += 1
        self._map_to_odom = se2_compose(match.pose, se2_inverse(odom))

    # --- results -------------------------------------------------------------------
    def finalize(self) -> float:
        """Batch Levenberg-Marquardt over the whole graph (end of an offline run or before
        saving); returns the graph cost.  ``map -> odom`` follows the optimised last
        node with odometry."""
        if not self.nodes:
            return 0.0
        cost = self._optimize()
        self._refresh_poses(full=True)
        for node in reversed(self.nodes):
            if not np.isnan(node.odom).any():
                self._map_to_odom = se2_compose(self._poses[node.node_id],
                                                se2_inverse(node.odom))
                break
        return cost

    def trajectory(self, odom_poses: FloatArray, node_index: NDArray[np.int64]) -> FloatArray:
        """Map poses of arbitrary odometry poses: each is attached to the node
        ``node_index[k]`` (the last node at its time, -1 for none) by its odometry offset
        from that node.  Scans that became nodes get their optimised node pose."""
        odom = np.asarray(odom_poses, float).reshape(-1, 3)
        out = np.empty_like(odom)
        poses = self.poses()
        for k, (o, n) in enumerate(zip(odom, node_index, strict=True)):
            if n < 0:
                out[k] = se2_compose(poses[0], se2_between(self.nodes[0].odom, o)) \
                    if self.nodes else o
            elif np.isnan(self.nodes[n].odom).any() or np.isnan(o).any():
                out[k] = poses[n]
            else:
                out[k] = se2_compose(poses[n], se2_between(self.nodes[n].odom, o))
        return out

    def live_map(self, recent: Sequence[tuple[NDArray[np.floating], FloatArray]] = ()
                 ) -> LogOddsGrid:
        """The map while mapping (:meth:`NodeMaps.live`)."""
        return self.maps.live(self.poses(), self.nodes, recent)

    def integrate_into(self, grid: LogOddsGrid, poses: FloatArray) -> None:
        """Draw every node's scan into ``grid`` at ``poses`` (N, 3) instead of its own
        (a map of the graph moved as a whole, e.g. aligned for scoring)."""
        self.maps.integrate(grid, np.asarray(poses, dtype=np.float64),
                            [node.ranges for node in self.nodes])

    def build_map(self, resolution: float | None = None, *,
                  incremental: bool = True) -> LogOddsGrid:
        """Occupancy grid of all node scans at their optimised poses
        (:meth:`NodeMaps.build`)."""
        return self.maps.build(self.poses(), self.nodes, resolution, incremental=incremental)

"""Graph SLAM from laser scans and odometry, the Karto / slam_toolbox way.

Per accepted scan (``minimum_travel_distance`` / ``minimum_travel_heading`` /
``minimum_time_interval`` gating, ``throttle_scans``):

1. predict the pose from the last node and the odometry increment;
2. match the scan against the *running buffer* (the last ``scan_buffer_size`` scans within
   ``scan_buffer_maximum_scan_distance``) with the correlative matcher
   (:mod:`navstack.mapping.scan_matcher`); a response of at least
   ``link_match_minimum_response_fine`` gives the node's pose and a scan-match edge,
   otherwise the odometry edge is used; reference points the new scan sees through at the
   predicted pose by more than ``dynamic_point_margin`` (a person who walked on) are
   left out of this match and of the fine loop match (:mod:`navstack.mapping.free_space`);
3. look for a loop closure: earlier nodes within ``loop_search_maximum_distance``, outside
   the current chain, grouped into chains of consecutive scans of at least
   ``loop_match_minimum_chain_size``; each chain is matched coarsely over
   ``loop_search_space_dimension`` (response >= ``loop_match_minimum_response_coarse``,
   variance <= ``loop_match_maximum_variance_coarse``, and -- navstack's addition -- no
   other place farther than ``loop_match_ambiguity_distance`` scoring more than
   ``loop_match_maximum_ambiguity`` times the best: on the Intel log this rejects all the
   corridor aliases that pass Karto's response tests) then finely
   (response >= ``loop_match_minimum_response_fine``); an accepted match becomes an edge
   from the chain's nearest scan;
4. optimise the pose graph incrementally (gtsam ISAM2, :mod:`navstack.mapping.pose_graph`).

``map -> odom`` is the last node's map pose composed with the inverse of its odometry pose.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import se2_between, se2_compose, se2_inverse
from navstack.mapping.free_space import seen_through
from navstack.mapping.icp import line_normals, refine_point_to_line
from navstack.mapping.occupancy import LogOddsGrid, ScanData
from navstack.mapping.pose_graph import PoseGraph
from navstack.mapping.scan_matcher import (
    LikelihoodGrid,
    MatchResult,
    SearchWindow,
    ambiguity,
    match_scan,
)
from navstack.mapping.slam_params import SlamParams

FloatArray = NDArray[np.float64]

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
    """A processed scan: graph node id, odometry pose, stamp, ranges."""

    node_id: int
    odom: FloatArray
    stamp: float
    ranges: NDArray[np.float32]
    points: FloatArray  # matching points in the base frame
    normals: FloatArray  # their local line normals (base frame), see mapping/icp.py
    line_like: NDArray[np.bool_]


@dataclass
class SlamStats:
    """Counters for health checks and benchmarks."""

    scans_received: int = 0
    scans_processed: int = 0
    match_failures: int = 0
    loop_closures: int = 0
    loop_attempts: int = 0
    loop_ambiguous: int = 0
    loop_implausible: int = 0


@dataclass
class _MapCache:
    """The grid :meth:`SlamMapper.build_map` built last, and what it holds."""

    resolution: float
    count: int
    poses: FloatArray
    last_node: ScanNode
    grid: LogOddsGrid


class SlamMapper:
    """Online pose-graph SLAM; feed :meth:`process_scan`, read poses / map / ``map->odom``."""

    def __init__(self, params: SlamParams, laser: LaserGeometry) -> None:
        self.params = params
        self.laser = laser
        self.graph = PoseGraph()
        self.nodes: list[ScanNode] = []
        self.stats = SlamStats()
        self._running: list[int] = []
        self._last_accepted_odom: FloatArray | None = None
        self._last_accepted_stamp = -math.inf
        self._map_to_odom = np.zeros(3)
        self._world_cache: dict[int, tuple[FloatArray, FloatArray]] = {}
        self._map_cache: _MapCache | None = None
        self.map_builds = [0, 0]
        """Maps built by :meth:`build_map` incrementally / from scratch."""
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
        self._loop_window = SearchWindow(
            dimension=params.loop_search_space_dimension,
            coarse_angle_offset=params.coarse_search_angle_offset,
            coarse_angle_resolution=params.coarse_angle_resolution,
            fine_angle_resolution=params.coarse_angle_resolution,
            distance_variance_penalty=1e9, angle_variance_penalty=1e9,
            minimum_distance_penalty=1.0, minimum_angle_penalty=1.0, refine=False)
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

    # --- serialization support (navstack.mapping.slam_io) ----------------------------
    def state(self) -> dict[str, Any]:
        """What besides nodes and graph a saved session needs to continue seamlessly."""
        last = self._last_accepted_odom
        return {"running": list(self._running), "map_to_odom": self._map_to_odom.copy(),
                "last_odom": np.full(3, np.nan) if last is None else last.copy(),
                "last_stamp": self._last_accepted_stamp}

    def restore_state(self, running: list[int], map_to_odom: FloatArray, last_odom: FloatArray,
                      last_stamp: float, start_pose: FloatArray | None = None) -> None:
        """Inverse of :meth:`state`.  With ``start_pose`` the next scan starts a new
        odometry frame at that map pose and is matched against the saved map there."""
        if self.params.mode == "localization":
            self.frozen_nodes = len(self.nodes)
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

    def _world_points(self, index: int, poses: FloatArray) -> FloatArray:
        node = self.nodes[index]
        pose = poses[index]
        cached = self._world_cache.get(index)
        if cached is not None and np.array_equal(cached[0], pose):
            return cached[1]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        world = node.points @ np.array([[c, s], [-s, c]]) + pose[:2]
        self._world_cache[index] = (pose.copy(), world)
        return world

    # --- gating ----------------------------------------------------------------------
    def _should_process(self, odom: FloatArray, stamp: float) -> bool:
        p = self.params
        self._scan_count += 1
        if self._last_accepted_odom is None:
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
    def process_scan(self, ranges: NDArray[np.floating], odom_pose: Sequence[float] | FloatArray,
                     stamp: float) -> bool:
        """Add a scan taken at ``odom_pose`` (odom frame); True when it became a node."""
        self.stats.scans_received += 1
        odom = np.asarray(odom_pose, float)
        if not self._should_process(odom, stamp):
            return False
        points = self.scan_points(ranges)
        if self._start_override is not None:  # first scan after a reload at a given pose
            self._map_to_odom = se2_compose(self._start_override, se2_inverse(odom))
            self._start_override = None
        if self.params.mode == "localization":
            self._localize(points, odom)
            self._last_accepted_odom, self._last_accepted_stamp = odom, stamp
            return False
        self.stats.scans_processed += 1
        normals, line_like = line_normals(points)
        node = ScanNode(len(self.nodes), odom, float(stamp),
                        np.asarray(ranges, np.float32).copy(), points, normals, line_like)
        if not self.nodes:
            start = self._start_pose(odom)
            self.nodes.append(node)
            self.graph.add_node(node.node_id, start)
            self.graph.update()
        else:
            self._add_linked_node(node)
            if self.params.do_loop_closing:
                self._try_loop_closures(node.node_id)
        self._running.append(node.node_id)
        self._trim_running()
        self._last_accepted_odom, self._last_accepted_stamp = odom, stamp
        last = self.graph.pose(node.node_id)
        self._map_to_odom = se2_compose(last, se2_inverse(odom))
        return True

    def _start_pose(self, odom: FloatArray) -> FloatArray:
        start = self.params.map_start_pose
        if start is not None:
            return np.asarray(start[:3], float)
        return odom.copy()

    def _predicted(self, odom: FloatArray) -> FloatArray:
        """Predicted map pose: the current ``map -> odom`` applied to the odometry pose
        (equal to the last node composed with the odometry increment since it)."""
        return se2_compose(self._map_to_odom, odom)

    def _nearest_nodes(self, pose: FloatArray) -> list[int]:
        poses = self.graph.poses()
        dist = np.hypot(*(poses[:, :2] - pose[:2]).T)
        near = np.flatnonzero(dist <= self.params.scan_buffer_maximum_scan_distance)
        return [int(i) for i in near[np.argsort(dist[near])][: self.params.scan_buffer_size]]

    def _match(self, reference_ids: Sequence[int], points: FloatArray, guess: FloatArray,
               window: SearchWindow, resolution: float, smear: float, block: int = 4,
               ranges: NDArray[np.floating] | None = None) -> MatchResult | None:
        """Correlative match (+ ICP polish); with the scan's ``ranges`` the reference
        points it sees through at ``guess`` are left out (``dynamic_point_margin``)."""
        keep = None if ranges is None else self._static_mask(reference_ids, ranges, guess)
        grid = self._grid(reference_ids, points, guess, window, resolution, smear, block, keep)
        if grid is None:
            return None
        match = match_scan(grid, points, guess, window)
        if not self.params.use_point_to_line_refinement:
            return match
        return self._polish(reference_ids, points, match, keep)

    def _static_mask(self, reference_ids: Sequence[int], ranges: NDArray[np.floating],
                     guess: FloatArray) -> NDArray[np.bool_] | None:
        """False for reference points the new scan sees through (moved objects, e.g.
        a person walking ahead), see :mod:`navstack.mapping.free_space`."""
        margin = self.params.dynamic_point_margin
        if margin <= 0.0 or len(reference_ids) == 0:
            return None
        poses = self.graph.poses()
        reference = np.vstack([self._world_points(i, poses) for i in reference_ids])
        laser = self.laser
        return ~seen_through(ranges, laser.angles, laser.range_min,
                             min(laser.range_max, self.params.max_laser_range),
                             se2_compose(guess, laser.mount), reference, margin)

    def _grid(self, reference_ids: Sequence[int], points: FloatArray, guess: FloatArray,
              window: SearchWindow, resolution: float, smear: float,
              block: int = 4, keep: NDArray[np.bool_] | None = None) -> LikelihoodGrid | None:
        """Likelihood grid of the reference scans (their ``keep`` points) covering the
        whole search."""
        if len(reference_ids) == 0 or points.shape[0] < 10:
            return None
        poses = self.graph.poses()
        reference = np.vstack([self._world_points(i, poses) for i in reference_ids])
        if keep is not None:
            reference = reference[keep]
            if reference.shape[0] == 0:
                return None
        c, s = math.cos(guess[2]), math.sin(guess[2])
        query = points @ np.array([[c, s], [-s, c]]) + guess[:2]
        reach = float(np.hypot(points[:, 0], points[:, 1]).max())
        # rotating by the angular window sweeps far points by reach * angle
        margin = (0.5 * window.dimension + reach * min(window.coarse_angle_offset, math.pi)
                  + 4 * smear)
        return LikelihoodGrid.around(reference, query, margin, resolution, smear, block)

    def _polish(self, reference_ids: Sequence[int], points: FloatArray,
                match: MatchResult, keep: NDArray[np.bool_] | None = None) -> MatchResult:
        """Point-to-line ICP from the correlative result; kept only within two search
        cells of it (the correlative search decides the basin)."""
        poses = self.graph.poses()
        refs, normals, masks = [], [], []
        for i in reference_ids:
            refs.append(self._world_points(i, poses))
            c, s = math.cos(poses[i, 2]), math.sin(poses[i, 2])
            normals.append(self.nodes[i].normals @ np.array([[c, s], [-s, c]]))
            masks.append(self.nodes[i].line_like)
        line_like = np.concatenate(masks)
        if keep is not None:
            line_like = line_like & keep
        refined, used = refine_point_to_line(np.vstack(refs), np.vstack(normals),
                                             line_like, points, match.pose)
        limit = 2.0 * self.params.correlation_search_space_resolution
        if used == 0 or math.hypot(*(refined[:2] - match.pose[:2])) > limit:
            return match
        return MatchResult(pose=refined, response=match.response, covariance=match.covariance)

    def _add_linked_node(self, node: ScanNode) -> None:
        p = self.params
        guess = self._predicted(node.odom)
        restarting = self._restart
        reference = self._nearest_nodes(guess) if restarting else self._running
        pose = guess
        match = None
        if p.use_scan_matching and restarting:
            coarse = self._match(reference, node.points, guess, self._loop_window,
                                 p.loop_search_space_resolution,
                                 p.loop_search_space_smear_deviation, block=8)
            if coarse is not None and coarse.response >= p.loop_match_minimum_response_coarse:
                match = self._match(reference, node.points, coarse.pose, self._window,
                                    p.correlation_search_space_resolution,
                                    p.correlation_search_space_smear_deviation)
        elif p.use_scan_matching:
            match = self._match(reference, self._covered(node.points, guess, reference),
                                guess, self._window,
                                p.correlation_search_space_resolution,
                                p.correlation_search_space_smear_deviation,
                                ranges=node.ranges)
        if match is not None and match.response >= p.link_match_minimum_response_fine:
            pose, cov = match.pose, match.covariance
        else:
            if p.use_scan_matching:
                self.stats.match_failures += 1
            anchor_pose = self.graph.pose(reference[0] if restarting and reference
                                          else self.nodes[-1].node_id)
            cov = _odometry_covariance(se2_between(anchor_pose, guess))
            if restarting:  # an unverified restart pose: tie it loosely
                cov = cov + np.diag([0.25, 0.25, 0.1])
        prev_id = reference[0] if restarting and reference else self.nodes[-1].node_id
        self.nodes.append(node)
        self.graph.add_node(node.node_id, pose)
        self.graph.add_edge(prev_id, node.node_id, se2_between(self.graph.pose(prev_id), pose),
                            np.linalg.inv(cov))
        self.graph.update()
        if restarting:
            self._running = []
            self._restart = False

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
        poses = self.graph.poses()
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
            poses = self.graph.poses()
            here = poses[self._running[-1], :2]
            self._running = [i for i in self._running
                             if np.hypot(*(poses[i, :2] - here))
                             <= p.scan_buffer_maximum_scan_distance]

    # --- loop closure ----------------------------------------------------------------
    def _loop_chains(self, node_id: int) -> list[list[int]]:
        """Chains of earlier scans near ``node_id`` (Karto ``FindPossibleLoopClosure``)."""
        p = self.params
        poses = self.graph.poses()
        near = np.hypot(*(poses[:node_id, :2] - poses[node_id, :2]).T) \
            <= p.loop_search_maximum_distance
        # the current chain: contiguous near scans leading up to this one are not loops
        k = node_id - 1
        while k >= 0 and near[k]:
            k -= 1
        chains: list[list[int]] = []
        current: list[int] = []
        for i in range(k + 1):
            if near[i]:
                current.append(i)
            elif current:
                chains.append(current)
                current = []
        if current:
            chains.append(current)
        return [c for c in chains if len(c) >= p.loop_match_minimum_chain_size]

    def _try_loop_closures(self, node_id: int) -> None:
        p = self.params
        node = self.nodes[node_id]
        closed = False
        for chain in self._loop_chains(node_id):
            self.stats.loop_attempts += 1
            guess = self.graph.pose(node_id)
            grid = self._grid(chain, node.points, guess, self._loop_window,
                              p.loop_search_space_resolution,
                              p.loop_search_space_smear_deviation, block=8)
            if grid is None:
                continue
            coarse = match_scan(grid, node.points, guess, self._loop_window)
            if coarse.response < p.loop_match_minimum_response_coarse:
                continue
            if ambiguity(grid, node.points, guess, coarse.pose, self._loop_window,
                         p.loop_match_ambiguity_distance) > p.loop_match_maximum_ambiguity:
                self.stats.loop_ambiguous += 1
                continue
            if max(coarse.covariance[0, 0], coarse.covariance[1, 1]) \
                    > p.loop_match_maximum_variance_coarse:
                continue
            fine = self._match(chain, node.points, coarse.pose, self._window,
                               p.correlation_search_space_resolution,
                               p.correlation_search_space_smear_deviation, ranges=node.ranges)
            if fine is None or fine.response < p.loop_match_minimum_response_fine:
                continue
            poses = self.graph.poses()
            anchor = chain[int(np.argmin(np.hypot(*(poses[chain, :2]
                                                    - fine.pose[:2]).T)))]
            measured = se2_between(poses[anchor], fine.pose)
            if not self._plausible_drift(anchor, node_id, measured, poses):
                self.stats.loop_implausible += 1
                continue
            self.graph.add_edge(anchor, node_id, measured, np.linalg.inv(fine.covariance),
                                robust_kernel=p.loop_closure_robust_kernel)
            self.stats.loop_closures += 1
            closed = True
        if closed:
            self.graph.update()
            self.graph.update()

    def _plausible_drift(self, anchor: int, node_id: int, measured: FloatArray,
                         poses: FloatArray) -> bool:
        """Would accepting the closure imply more drift than the path since ``anchor``
        can have accumulated?  The correction must stay below
        ``loop_match_maximum_drift_base + loop_match_maximum_drift_rate * path length``."""
        p = self.params
        current = se2_between(poses[anchor], poses[node_id])
        correction = se2_between(current, measured)
        lo, hi = sorted((anchor, node_id))
        path = float(np.hypot(*np.diff(poses[lo:hi + 1, :2], axis=0).T).sum())
        bound = p.loop_match_maximum_drift_base + p.loop_match_maximum_drift_rate * path
        return math.hypot(correction[0], correction[1]) <= bound

    # --- localization mode -----------------------------------------------------------
    def _localize(self, points: FloatArray, odom: FloatArray) -> None:
        """Match against the loaded graph's scans near the predicted pose; move map->odom."""
        p = self.params
        guess = self.pose_of(odom)
        poses = self.graph.poses()
        near = np.flatnonzero(np.hypot(*(poses[:, :2] - guess[:2]).T)
                              <= p.scan_buffer_maximum_scan_distance)
        if near.size == 0:
            self.stats.match_failures += 1
            return
        nearest = near[np.argsort(np.hypot(*(poses[near, :2] - guess[:2]).T))]
        match = self._match(list(nearest[: p.scan_buffer_size]), points, guess, self._window,
                            p.correlation_search_space_resolution,
                            p.correlation_search_space_smear_deviation)
        if match is None or match.response < p.link_match_minimum_response_fine:
            self.stats.match_failures += 1
            return
        self.stats.scans_processed += 1
        self._map_to_odom = se2_compose(match.pose, se2_inverse(odom))

    # --- results -------------------------------------------------------------------
    def finalize(self) -> float:
        """Batch Levenberg-Marquardt over the whole graph (end of an offline run or before
        saving); returns the graph cost.  ``map -> odom`` follows the optimised last node."""
        if not self.nodes:
            return 0.0
        cost = self.graph.optimize()
        last = self.nodes[-1]
        self._map_to_odom = se2_compose(self.graph.pose(last.node_id), se2_inverse(last.odom))
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
            else:
                out[k] = se2_compose(poses[n], se2_between(self.nodes[n].odom, o))
        return out

    def build_map(self, resolution: float | None = None, *,
                  incremental: bool = True) -> LogOddsGrid:
        """Occupancy grid of all node scans at their optimised poses.

        The grid of the previous call is kept: when the nodes it holds are still the
        first nodes, at exactly the same poses (no loop closure or relinearisation moved
        them), only the new nodes' scans are added to it -- the same log-odds updates in
        the same order as a rebuild, on the same lattice (world (0, 0)), so the same map,
        at a cost that no longer grows with the number of nodes.  ``incremental=False``
        always rebuilds from every node.
        """
        res = self.params.resolution if resolution is None else resolution
        if not self.nodes:
            return LogOddsGrid(res)
        poses = self.poses()
        n = min(len(self.nodes), poses.shape[0])  # asynchronous SLAM may be adding one
        poses = poses[:n]
        if n == 0:
            return LogOddsGrid(res)
        cache = self._map_cache if incremental else None
        start = 0
        if (cache is not None and cache.resolution == res and 0 < cache.count <= n
                and self.nodes[cache.count - 1] is cache.last_node
                and np.array_equal(poses[:cache.count], cache.poses)):
            grid, start = cache.grid, cache.count
        else:
            grid = LogOddsGrid(res)
        if start < n:
            usable = min(self.laser.range_max, self.params.max_laser_range)
            scans = [ScanData(node.ranges.astype(float), self.laser.angles,
                              self.laser.range_min, self.laser.range_max)
                     for node in self.nodes[start:n]]
            grid.integrate_scans(poses[start:], scans, usable, sensor_pose=self.laser.mount)
        if incremental:
            self._map_cache = _MapCache(res, n, poses.copy(), self.nodes[n - 1], grid)
            self.map_builds[0 if start else 1] += 1
            return grid.copy()
        return grid


def _odometry_covariance(delta: FloatArray) -> FloatArray:
    """Covariance of an odometry-only edge: 10% of the motion plus a floor."""
    dist = math.hypot(delta[0], delta[1])
    sxy = 0.05 + 0.1 * dist
    sth = 0.05 + 0.1 * abs(delta[2])
    return np.diag([sxy * sxy, sxy * sxy, sth * sth])

"""Loop closure for :class:`~navstack.mapping.slam.SlamMapper`: where to look, how wide,
and which matches to believe.

*Where and how wide.*  Karto looks for loop candidates within a fixed radius
(``loop_search_maximum_distance``) and searches a fixed window
(``loop_search_space_dimension``); after a long loop the drift exceeds both and the loop
is never closed (a campus road comes out doubled).  Here both follow the pose graph's
uncertainty.  Every node stores its marginal covariance when it is added (ISAM2, cheap
for the newest node); the uncertainty of the current pose *relative to* an older node
``a`` is approximated as

    Sigma_rel = Sigma_cur - Ad Sigma_a Ad^T      (clamped to >= 0, plus a floor)

with ``Ad`` the adjoint that carries ``a``'s tangent space to the current node's -- exact
on a chain of odometry / scan-match edges, where the covariance of the newest pose is the
old node's propagated plus what the chain added since.  A node is a candidate when it is
within ``loop_search_maximum_distance + loop_search_drift_sigmas * sigma`` of the current
pose, and the search window around the predicted pose is that many sigmas wide (at least
``loop_search_space_dimension``, at most ``loop_search_maximum_space_dimension``; angles
at least ``coarse_search_angle_offset``, up to the full circle).  Nodes contiguous with
the current one inside their region are the current chain, never a loop (Karto).

*Against what.*  Candidates are grouped by submap (:mod:`navstack.mapping.submaps`); at
most ``loop_search_maximum_candidates`` submaps, nearest in sigmas first, are tried per
node, each with the branch-and-bound matcher (:mod:`navstack.mapping.fast_matcher`).

*Which matches.*  The response tests of slam_toolbox (coarse and fine) and the fine
response against the links' typical one (``loop_match_minimum_response_ratio``), then the
uniqueness test: no pose farther than ``loop_match_ambiguity_distance`` from the best may
score ``loop_match_maximum_ambiguity`` times the best.  When every such rival lies on one
line through the best pose at the same heading -- a corridor, whose walls fix the
lateral position and the heading but not the position along it -- the closure is kept
with a covariance that leaves the along-corridor direction free
(``loop_match_corridor_closures``): it still removes a doubled corridor.  Then the drift
bound, the free-space test (the scan may not see through the submap's static structure:
``loop_match_maximum_seen_through_ratio``), the confirmation by an agreeing closure
against another submap (``loop_match_confirmation_distinct_submaps``), the position
inside the window (``loop_match_maximum_window_fraction``: not at its edge) and, after the
optimiser took the closure in, the chi-square test of its residual
(``loop_closure_maximum_chi2``; see :meth:`LoopCloser.reject_outliers`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from navstack.core.geometry import se2_compose
from navstack.mapping.fast_matcher import (
    Exclusion,
    PrecomputedGrids,
    WideWindow,
    angle_step,
    surface_covariance,
    voxel_filter,
    wide_match,
)
from navstack.mapping.free_space import seen_through_beams, static_points
from navstack.mapping.icp import refine_point_to_line
from navstack.mapping.submaps import Submap, SubmapPoints, Submaps

if TYPE_CHECKING:
    from navstack.mapping.slam import SlamMapper

FloatArray = NDArray[np.float64]

__all__ = ["LoopCandidate", "LoopCloser", "LoopClosure", "relative_covariances"]

#: translational floor of the relative uncertainty [m] (one std)
_SIGMA_FLOOR_M = 0.05
_SIGMA_FLOOR_RAD = math.radians(1.0)


def relative_covariances(current: FloatArray, current_cov: FloatArray, poses: FloatArray,
                         covs: FloatArray) -> FloatArray:
    """``(M, 3, 3)`` covariance of the current pose relative to each of ``poses``
    ``(M, 3)`` whose marginals were ``covs`` ``(M, 3, 3)`` (all in gtsam's Pose2 tangent
    space, the current node's frame); see the module docstring."""
    dx = poses[:, 0] - current[0]
    dy = poses[:, 1] - current[1]
    c0, s0 = math.cos(current[2]), math.sin(current[2])
    # pose of each node in the current frame (z^-1)
    x = c0 * dx + s0 * dy
    y = -s0 * dx + c0 * dy
    th = poses[:, 2] - current[2]
    c, s = np.cos(th), np.sin(th)
    ad = np.zeros((poses.shape[0], 3, 3))
    ad[:, 0, 0], ad[:, 0, 1], ad[:, 0, 2] = c, -s, y
    ad[:, 1, 0], ad[:, 1, 1], ad[:, 1, 2] = s, c, -x
    ad[:, 2, 2] = 1.0
    rel = current_cov[None] - ad @ covs @ np.swapaxes(ad, 1, 2)
    rel = 0.5 * (rel + np.swapaxes(rel, 1, 2))
    w, v = np.linalg.eigh(rel)
    rel = (v * np.maximum(w, 0.0)[:, None, :]) @ np.swapaxes(v, 1, 2)
    floor = np.diag([_SIGMA_FLOOR_M**2, _SIGMA_FLOOR_M**2, _SIGMA_FLOOR_RAD**2])
    return rel + floor[None]


@dataclass(frozen=True)
class LoopCandidate:
    """A submap to try, the current pose in its anchor frame and the window."""

    submap: Submap
    guess: FloatArray
    window: WideWindow
    distance_sigmas: float


@dataclass(frozen=True, eq=False)
class LoopClosure:
    """An accepted closure: edge ``anchor -> node`` with its measurement and covariance
    (in the edge's tangent space), and whether it is a corridor closure."""

    anchor: int
    node: int
    measurement: FloatArray
    covariance: FloatArray
    response: float
    corridor: bool


class LoopCloser:
    """Candidate search, matching and confirmation for one mapper (module docstring)."""

    def __init__(self, mapper: SlamMapper) -> None:
        self.mapper = mapper
        p = mapper.params
        self.submaps = Submaps(p.loop_match_submap_size, p.loop_search_space_resolution,
                               p.loop_search_space_smear_deviation)
        self._pending: list[LoopClosure] = []
        self._recent: list[LoopClosure] = []
        self._tried_at: dict[int, int] = {}    # submap index -> last node matched to it

    # --- confirmation --------------------------------------------------------------------
    def confirm(self, found: list[LoopClosure], node_id: int,
                poses: FloatArray) -> list[LoopClosure]:
        """The closures to add now: those that agree with another closure found within
        ``loop_match_confirmation_nodes`` nodes (pending ones it confirms included).  A
        true revisit yields a run of closures that all imply the same correction of the
        new path; a false match (an alias that passed every test) is usually alone.
        The partner must be against another submap
        (``loop_match_confirmation_distinct_submaps``), except between closures that each
        move their node by at most ``loop_match_same_submap_confirmation_distance``.
        Unconfirmed closures wait that many nodes, then are dropped."""
        window = self.mapper.params.loop_match_confirmation_nodes
        if window <= 0:
            return found
        self._pending = [c for c in self._pending if node_id - c.node <= window]
        self._recent = [c for c in self._recent if node_id - c.node <= window]
        distinct = self.mapper.params.loop_match_confirmation_distinct_submaps
        small = self.mapper.params.loop_match_same_submap_confirmation_distance
        accepted: list[LoopClosure] = []
        for c in found:
            others = [o for o in (*self._recent, *self._pending, *found) if o is not c]
            partners = [o for o in others if not (distinct and o.anchor == c.anchor)
                        and _agree(c, o, poses)]
            if not partners and distinct and small > 0.0 \
                    and _correction(c, poses) <= small:
                partners = [o for o in others if o.anchor == c.anchor and o.node != c.node
                            and _correction(o, poses) <= small and _agree(c, o, poses)]
            if not partners:
                self._pending.append(c)
                continue
            accepted.append(c)
            for o in partners:
                if o in self._pending:
                    self._pending.remove(o)
                    accepted.append(o)
        accepted = list({id(c): c for c in accepted}.values())
        self._recent.extend(accepted)
        self.mapper.stats.loop_unconfirmed = len(self._pending)
        return accepted

    # --- candidates ----------------------------------------------------------------------
    def candidates(self, node_id: int, poses: FloatArray, covs: FloatArray,
                   current_cov: FloatArray) -> list[LoopCandidate]:
        """Submaps worth matching the node against, nearest (in sigmas) first."""
        p = self.mapper.params
        complete = self.submaps.complete()
        if not complete or node_id < 1:
            return []
        cur = poses[node_id]
        base = p.loop_search_maximum_distance
        n_sig = p.loop_search_drift_sigmas
        # coarse prefilter: no relative uncertainty exceeds the current marginal's
        sig_max = math.sqrt(max(float(np.linalg.eigvalsh(current_cov[:2, :2])[-1]), 0.0))
        d = np.hypot(poses[:node_id, 0] - cur[0], poses[:node_id, 1] - cur[1])
        reach = base + n_sig * (sig_max + _SIGMA_FLOOR_M)
        near = np.flatnonzero(d <= reach)
        if near.size == 0:
            return []
        rel = relative_covariances(cur, current_cov, poses[near], covs[near])
        sig = np.sqrt(np.linalg.eigvalsh(rel[:, :2, :2])[:, -1])
        radius = base + n_sig * sig
        inside = d[near] <= radius
        region = np.zeros(node_id, bool)
        region[near[inside]] = True
        # the current chain: nodes leading up to this one without leaving their region
        k = node_id - 1
        while k >= 0 and region[k]:
            region[k] = False
            k -= 1
        chain_start = k + 1
        by_submap: dict[int, tuple[float, int]] = {}
        for idx, r, dist in zip(near, radius, d[near], strict=True):
            if not region[idx]:
                continue
            sm = self.submaps.of_node(int(idx))
            score = dist / r
            if sm not in by_submap or score < by_submap[sm][0]:
                by_submap[sm] = (score, int(idx))
        chain_submaps = {self.submaps.of_node(i) for i in range(chain_start, node_id + 1)}
        # a submap matched a few nodes ago (closed or not) is not tried again yet: the
        # view has barely changed, and a revisit yields a closure every few nodes anyway
        spacing = p.loop_search_node_interval
        ranked = sorted((v[0], sm) for sm, v in by_submap.items()
                        if sm < len(complete) and sm not in chain_submaps
                        and node_id - self._tried_at.get(sm, -spacing) >= spacing)
        out = []
        for score, sm in ranked[: p.loop_search_maximum_candidates]:
            self._tried_at[sm] = node_id
            submap = complete[sm]
            out.append(self._candidate(submap, cur, current_cov, poses, covs, score))
        return out

    def _candidate(self, submap: Submap, cur: FloatArray, current_cov: FloatArray,
                   poses: FloatArray, covs: FloatArray, score: float) -> LoopCandidate:
        p = self.mapper.params
        a = submap.anchor
        rel = relative_covariances(cur, current_cov, poses[a][None], covs[a][None])[0]
        ca, sa = math.cos(poses[a, 2]), math.sin(poses[a, 2])
        dx, dy = cur[0] - poses[a, 0], cur[1] - poses[a, 1]
        guess = np.array([ca * dx + sa * dy, -sa * dx + ca * dy,
                          math.remainder(cur[2] - poses[a, 2], 2 * math.pi)])
        # current position in the anchor frame moves by R(theta_z) * body perturbation
        cz, sz = math.cos(guess[2]), math.sin(guess[2])
        rz = np.array([[cz, -sz], [sz, cz]])
        cov_xy = rz @ rel[:2, :2] @ rz.T
        n_sig = p.loop_search_drift_sigmas
        lo = 0.5 * p.loop_search_space_dimension
        hi = 0.5 * p.loop_search_maximum_space_dimension
        half_x = min(max(lo, n_sig * math.sqrt(cov_xy[0, 0])), hi)
        half_y = min(max(lo, n_sig * math.sqrt(cov_xy[1, 1])), hi)
        half_a = min(max(p.loop_search_minimum_angle_offset, n_sig * math.sqrt(rel[2, 2])),
                     math.pi)
        return LoopCandidate(submap, guess, WideWindow(half_x, half_y, half_a), score)

    # --- matching ------------------------------------------------------------------------
    def match(self, node_id: int, candidate: LoopCandidate, poses: FloatArray
              ) -> LoopClosure | None:
        """Match the node's scan in the candidate submap; ``None`` if any test fails."""
        m = self.mapper
        p = m.params
        stats = m.stats
        stats.loop_attempts += 1
        m.refresh_poses(candidate.submap.nodes)
        drawn = self.submaps.points(candidate.submap, poses, m.nodes)
        window = candidate.window
        points = m.nodes[node_id].points
        if len(drawn.points) == 0 or len(points) == 0:
            # a submap (or scan) of open space beyond the lidar's range holds nothing to
            # match: no closure (a short-range lidar's sparse nodes, issue 16 warehouse)
            return None
        # a wide window is searched on a coarser raster first (the submap's coarse grids)
        coarse = max(window.half_x, window.half_y) > 8.0 * self.submaps.resolution \
            or window.half_angle > 0.35
        grids = self.submaps.grids(candidate.submap, drawn, coarse=coarse)
        query = voxel_filter(points, grids.resolution)
        window = replace(window, angle_step=angle_step(query, grids.resolution))
        best = wide_match(grids, query, candidate.guess, window,
                          min_score=p.loop_match_minimum_response_coarse)
        if best is None:
            return None
        corridor: FloatArray | None = None
        rival = wide_match(grids, query, candidate.guess, window,
                           min_score=best.score * p.loop_match_maximum_ambiguity,
                           exclusion=Exclusion((best.pose[0], best.pose[1]), (1.0, 0.0),
                                               p.loop_match_ambiguity_distance,
                                               p.loop_match_ambiguity_distance, 0.0, math.pi))
        if rival is not None:
            corridor = self._corridor(grids, query, candidate.guess, window, best.pose,
                                      best.score, rival.pose) \
                if p.loop_match_corridor_closures else None
            if corridor is None:
                stats.loop_ambiguous += 1
                return None
        if coarse:
            # refine on the fine grids within two coarse cells and angle steps
            fine_grids = self.submaps.grids(candidate.submap, drawn)
            step = 2.0 * grids.resolution
            refined = wide_match(fine_grids, voxel_filter(points, fine_grids.resolution),
                                 best.pose, WideWindow(step, step, 0.05),
                                 min_score=p.loop_match_minimum_response_coarse)
            if refined is None:
                return None
            best = refined
        # polish against the submap's own points (point-to-line ICP) and judge the fit on
        # the fine grids: no new raster per attempt
        fine_grids = self.submaps.grids(candidate.submap, drawn)
        pose = best.pose
        polished, used = refine_point_to_line(drawn.points, drawn.normals, drawn.line_like,
                                              points, pose)
        if used and math.hypot(*(polished[:2] - pose[:2])) <= 2.0 * fine_grids.resolution:
            pose = polished
        surface, response = surface_covariance(fine_grids, voxel_filter(points,
                                                                        fine_grids.resolution),
                                               pose, 0.5 * p.correlation_search_space_dimension,
                                               p.coarse_angle_resolution)
        if response < p.loop_match_minimum_response_fine:
            return None
        # a closure that explains far fewer of its points than the links usually do sees
        # the place only partly (a room seen from the corridor through its door, the
        # scan reaching where the submap never looked): the points only it sees pull the
        # fit towards the walls the submap has, by centimetres, in the same direction at
        # every node of the revisit -- the office route's closures below 0.75 of the
        # links' typical response were off by 5-12 cm, those above it by <= 3 cm
        typical = m.typical_response()
        if typical < 1.0 and response < p.loop_match_minimum_response_ratio * typical:
            stats.loop_weak += 1
            return None
        unit = m.match_unit()
        cov = surface + np.diag(unit * unit)
        # below the links' response the fit is less certain than its response surface
        # says: variance grows with the misfit squared relative to the links' (Hector /
        # Karto scale their covariance so)
        if typical < 1.0 and response < typical:
            cov = cov * ((1.0 - response) / (1.0 - typical)) ** 2
        if corridor is not None:
            # free along the corridor: a variance of the window's extent along it
            along = max(window.half_x, window.half_y) ** 2
            cov[:2, :2] += along * np.outer(corridor, corridor)
            stats.loop_corridor += 1
        elif max(cov[0, 0], cov[1, 1]) > p.loop_match_maximum_variance_coarse:
            return None
        anchor = candidate.submap.anchor
        measured = pose.copy()
        if corridor is None and _at_window_edge(measured, candidate,
                                                p.loop_match_maximum_window_fraction):
            stats.loop_window_edge += 1
            return None
        if not self._plausible_drift(anchor, node_id, measured, poses):
            stats.loop_implausible += 1
            return None
        if self._seen_through(node_id, candidate.submap, drawn, measured):
            stats.loop_seen_through += 1
            return None
        return LoopClosure(anchor, node_id, measured, tangent_covariance(cov, measured[2]),
                           response, corridor is not None)

    def _seen_through(self, node_id: int, submap: Submap, drawn: SubmapPoints,
                      pose: FloatArray) -> bool:
        """Does the node's scan, at the matched ``pose`` (anchor frame), pass through the
        submap's static structure on more than ``loop_match_maximum_seen_through_ratio``
        beams per beam whose return lands on it (within two loop-grid cells)?

        The correlative score only counts returns that land on the submap; a place the
        scan sees *empty* where the submap holds a pillar scores nothing against the fit.
        In a warehouse whose racks repeat every 3.5 m, a short-range lidar that sees two
        rack ends fits as well one or two racks along (issue 16, seed 3: a closure 7 m
        off, its scan's no-return beams through the pillar the submap held 1.3 m away).
        Beams without a return are free space up to the usable range (the map clears
        them too).  Submap points another scan of the submap sees through are left out
        (a forklift or a person drawn by one scan, gone in the next: free_space.py).
        Measured on the warehouse exploration: true closures 0-0.23 such beams per
        agreeing beam, the aliased ones 0.36-0.76."""
        m = self.mapper
        p = m.params
        ratio = p.loop_match_maximum_seen_through_ratio
        if ratio <= 0.0 or len(drawn.points) == 0:
            return False
        laser = m.laser
        usable = min(laser.range_max, p.max_laser_range)
        margin = 2.0 * p.loop_search_space_resolution
        members = submap.nodes
        owner = np.concatenate([np.full(m.nodes[i].points.shape[0], j, np.int64)
                                for j, i in enumerate(members)])
        sensors = np.array([se2_compose(rel, laser.mount) for rel in drawn.relative])
        static = static_points(drawn.points, owner, [m.nodes[i].ranges for i in members],
                               sensors, laser.angles, laser.range_min, laser.range_max,
                               margin, usable)
        if not static.any():
            return False
        structure = drawn.points[static]
        sensor = se2_compose(pose, laser.mount)
        ranges = np.asarray(m.nodes[node_id].ranges, float)
        beams = seen_through_beams(ranges, laser.angles, laser.range_min, laser.range_max,
                                   sensor, structure, margin, free_range=usable)
        conflicts = np.unique(beams[beams >= 0]).size
        if conflicts == 0:
            return False
        real = np.flatnonzero(np.isfinite(ranges) & (ranges >= laser.range_min)
                              & (ranges < usable))
        heading = sensor[2] + laser.angles[real]
        ends = np.column_stack((sensor[0] + ranges[real] * np.cos(heading),
                                sensor[1] + ranges[real] * np.sin(heading)))
        near, _ = cKDTree(structure).query(ends, distance_upper_bound=margin)
        agreeing = int(np.count_nonzero(np.isfinite(near)))
        return conflicts > ratio * max(agreeing, 1)

    def _corridor(self, grids: PrecomputedGrids, query: FloatArray, guess: FloatArray,
                  window: WideWindow, best: FloatArray, score: float,
                  rival: FloatArray) -> FloatArray | None:
        p = self.mapper.params
        return corridor_direction(grids, query, guess, window, best, score, rival,
                                  p.loop_match_maximum_ambiguity,
                                  p.loop_match_ambiguity_distance)

    def _plausible_drift(self, anchor: int, node_id: int, measured: FloatArray,
                         poses: FloatArray) -> bool:
        """The correction a closure implies stays below ``loop_match_maximum_drift_base
        + loop_match_maximum_drift_rate * path length`` since the anchor."""
        p = self.mapper.params
        ca, sa = math.cos(poses[anchor, 2]), math.sin(poses[anchor, 2])
        dx, dy = poses[node_id, 0] - poses[anchor, 0], poses[node_id, 1] - poses[anchor, 1]
        current = np.array([ca * dx + sa * dy, -sa * dx + ca * dy])
        correction = math.hypot(*(measured[:2] - current))
        lo, hi = sorted((anchor, node_id))
        path = float(np.hypot(*np.diff(poses[lo:hi + 1, :2], axis=0).T).sum())
        bound = p.loop_match_maximum_drift_base + p.loop_match_maximum_drift_rate * path
        return correction <= bound


def corridor_direction(grids: PrecomputedGrids, query: FloatArray, guess: FloatArray,
                       window: WideWindow, best: FloatArray, score: float, rival: FloatArray,
                       ratio: float, distance: float) -> FloatArray | None:
    """Unit direction of a corridor if every strong rival of ``best`` (scoring at least
    ``ratio`` times ``score``) lies on the line from ``best`` through ``rival`` at
    ``best``'s heading (within ``distance`` of it and 2 degrees), else ``None``."""
    if abs(math.remainder(rival[2] - best[2], 2 * math.pi)) > 2 * math.radians(2.0):
        return None
    u = rival[:2] - best[:2]
    u = u / max(float(np.hypot(u[0], u[1])), 1e-9)
    other = wide_match(grids, query, guess, window, min_score=score * ratio,
                       exclusion=Exclusion((best[0], best[1]), (float(u[0]), float(u[1])),
                                           4.0 * max(window.half_x, window.half_y), distance,
                                           best[2], math.radians(2.0)))
    return u if other is None else None


def _at_window_edge(pose: FloatArray, candidate: LoopCandidate, fraction: float) -> bool:
    """Does ``pose`` (anchor frame) lie farther from the window's centre (the guess) than
    ``fraction`` of the window's half-size along x or y (0 = never)?  The correlative
    score still rose towards the window's edge there, so the optimum may lie outside: in
    the warehouse's aisles (issue 16, seed 3) such closures slid 1.1-1.4 m along the racks
    with a good response while the guess was 0.1-0.25 m from the truth; of 244 true
    non-corridor closures of that run none was beyond 0.9 of the window, two beyond 0.8."""
    if fraction <= 0.0:
        return False
    w = candidate.window
    off = pose[:2] - candidate.guess[:2]
    return abs(float(off[0])) > fraction * w.half_x or abs(float(off[1])) > fraction * w.half_y


def _agree(a: LoopClosure, b: LoopClosure, poses: FloatArray) -> bool:
    """Do two closures move the new path the same way?  Each implies a corrected pose of
    its node (anchor pose composed with the measurement); applying ``a``'s correction to
    ``b``'s node must land within 3 sigmas (both closures' covariances plus the chain
    between the two nodes, floored) of where ``b`` puts it."""
    wa = _compose(poses[a.anchor], a.measurement)
    wb = _compose(poses[b.anchor], b.measurement)
    # correction T = wa * x_a^-1, applied to b's node
    corr = _compose(wa, _between(poses[a.node], poses[b.node]))
    d = _between(wb, corr)
    d[2] = math.remainder(d[2], 2 * math.pi)
    chain = max(abs(a.node - b.node), 1)
    floor = np.diag([(_SIGMA_FLOOR_M * chain) ** 2] * 2 + [(_SIGMA_FLOOR_RAD * chain) ** 2])
    cov = a.covariance + b.covariance + floor
    return float(d @ np.linalg.solve(cov, d)) <= 9.0


def _correction(c: LoopClosure, poses: FloatArray) -> float:
    """How far [m] the closure would move its node: the node's pose implied by the
    anchor and the measurement against its pose now."""
    implied = _compose(poses[c.anchor], c.measurement)
    return math.hypot(float(implied[0] - poses[c.node, 0]),
                      float(implied[1] - poses[c.node, 1]))


def _compose(a: FloatArray, b: FloatArray) -> FloatArray:
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]])


def _between(a: FloatArray, b: FloatArray) -> FloatArray:
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy,
                     math.remainder(b[2] - a[2], 2 * math.pi)])


def tangent_covariance(cov_xy_frame: FloatArray, heading: float) -> FloatArray:
    """A match covariance over ``(x, y, theta)`` in the reference frame, expressed in the
    tangent space of the matched pose (gtsam's BetweenFactor error is in the frame of the
    measured pose): the translation block rotated by ``-heading``."""
    c, s = math.cos(heading), math.sin(heading)
    j = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    out = j @ cov_xy_frame @ j.T
    return 0.5 * (out + out.T)

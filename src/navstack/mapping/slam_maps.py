"""The SLAM graph's node scans drawn into occupancy grids: the live map published while
mapping and the full map of every node at its optimised pose.

Both keep their grid between calls and only add the new nodes' scans while the nodes
already drawn have not moved (no loop closure moved them), so the cost of a map no
longer grows with the number of nodes.  Split out of :mod:`navstack.mapping.slam`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from navstack.mapping.occupancy import LogOddsGrid, ScanData
from navstack.mapping.slam_params import SlamParams

if TYPE_CHECKING:
    from navstack.mapping.slam import LaserGeometry, ScanNode

FloatArray = NDArray[np.float64]

__all__ = ["NodeMaps", "drop_isolated_no_returns"]


@dataclass
class _MapCache:
    """The grid :meth:`NodeMaps.build` built last, and what it holds."""

    resolution: float
    count: int
    poses: FloatArray
    last_node: ScanNode
    grid: LogOddsGrid


class NodeMaps:
    """Occupancy grids of a SLAM graph's node scans, kept between calls."""

    def __init__(self, params: SlamParams, laser: LaserGeometry) -> None:
        self.params = params
        self.laser = laser
        self._live_grid: LogOddsGrid | None = None  # live()'s kept grid
        self._live_count = 0
        self._live_poses = np.zeros((0, 3))
        self.cache: _MapCache | None = None
        """What :meth:`build` drew last (reused while its nodes have not moved)."""
        self.builds = [0, 0]
        """Maps built by :meth:`build` incrementally / from scratch."""

    def live(self, poses: FloatArray, nodes: Sequence[ScanNode],
             recent: Sequence[tuple[NDArray[np.floating], FloatArray]] = ()) -> LogOddsGrid:
        """The map while mapping, cheap enough to publish every second: the scans of
        ``nodes`` (at ``poses``) are added to a kept grid as they come (all of them again
        only when the graph moved a drawn node by more than half a cell or a fifth of a
        degree -- a loop closure), and a copy of it gets the free space of the ``recent``
        scans ``(ranges, map pose)`` on top (``clear_only``: a person who walked away is
        cleared by the latest scans, not only by the next node's).  The SLAM node
        publishes it without ``recent``: in the office route that overlay eroded walls
        the planner then routed through (docs/mapping.md, "Online")."""
        res = self.params.resolution
        n_done = self._live_count
        if self._live_grid is None or n_done > poses.shape[0] or (n_done and _moved(
                self._live_poses[:n_done], poses[:n_done], 0.5 * res, math.radians(0.2))):
            self._live_grid = LogOddsGrid(res)
            n_done = 0
        grid = self._live_grid
        if poses.shape[0] > n_done:
            self.integrate(grid, poses[n_done:], [n.ranges for n in nodes[n_done:]])
            self._live_count = poses.shape[0]
            self._live_poses = poses.copy()
        if not recent:
            return grid
        out = grid.copy()
        self.integrate(out, np.array([pose for _, pose in recent]),
                       [ranges for ranges, _ in recent], clear_only=True)
        return out

    def integrate(self, grid: LogOddsGrid, poses: FloatArray,
                  ranges: Sequence[NDArray[np.floating]], clear_only: bool = False) -> None:
        """Draw scans ``ranges`` taken at map ``poses`` into ``grid`` (isolated
        no-return beams dropped, :func:`drop_isolated_no_returns`)."""
        usable = min(self.laser.range_max, self.params.max_laser_range)
        full_circle = bool(np.ptp(self.laser.angles) > 1.9 * math.pi)
        scans = [ScanData(drop_isolated_no_returns(np.asarray(r, dtype=float),
                                                   self.laser.range_min,
                                                   self.laser.range_max, full_circle),
                          self.laser.angles, self.laser.range_min, self.laser.range_max)
                 for r in ranges]
        grid.integrate_scans(poses, scans, usable, sensor_pose=self.laser.mount,
                             clear_only=clear_only)

    def build(self, poses: FloatArray, nodes: Sequence[ScanNode],
              resolution: float | None = None, *, incremental: bool = True) -> LogOddsGrid:
        """Occupancy grid of the scans of ``nodes`` at their optimised ``poses``.

        The grid of the previous call is kept: when the nodes it holds are still the
        first nodes, at exactly the same poses (no loop closure or relinearisation moved
        them), only the new nodes' scans are added to it -- the same log-odds updates in
        the same order as a rebuild, on the same lattice (world (0, 0)), so the same map,
        at a cost that no longer grows with the number of nodes.  ``incremental=False``
        always rebuilds from every node.  (:meth:`live`, the published map, keeps its own
        grid and tolerates half a cell of pose change before it redraws.)
        """
        res = self.params.resolution if resolution is None else resolution
        n = min(len(nodes), poses.shape[0])  # asynchronous SLAM may be adding one
        if n == 0:
            return LogOddsGrid(res)
        poses = poses[:n]
        cache = self.cache if incremental else None
        start = 0
        if (cache is not None and cache.resolution == res and 0 < cache.count <= n
                and nodes[cache.count - 1] is cache.last_node
                and np.array_equal(poses[:cache.count], cache.poses)):
            grid, start = cache.grid, cache.count
        else:
            grid = LogOddsGrid(res)
        if start < n:
            self.integrate(grid, poses[start:], [node.ranges for node in nodes[start:n]])
        if incremental:
            self.cache = _MapCache(res, n, poses.copy(), nodes[n - 1], grid)
            self.builds[0 if start else 1] += 1
            return grid.copy()
        return grid


def _moved(a: FloatArray, b: FloatArray, distance: float, angle: float) -> bool:
    """Did any pose move by more than ``distance`` or ``angle``?"""
    d = b - a
    return bool(np.any(np.hypot(d[:, 0], d[:, 1]) > distance)
                or np.any(np.abs(np.remainder(d[:, 2] + math.pi, 2 * math.pi) - math.pi)
                          > angle))


def drop_isolated_no_returns(ranges: FloatArray, range_min: float, range_max: float,
                             wrap: bool, run: int = 2) -> FloatArray:
    """``ranges`` with every run of at most ``run`` beams without a return (at or beyond
    ``range_max``) between two beams with returns set to NaN (dropped).

    A map clears along no-return beams up to the usable range (slam_toolbox does); a
    single beam that misses its wall (dropout, a dark or glossy spot) would cut a free
    line through the wall and far behind it -- a gap the planner takes.  An open
    direction (a door, a long corridor) spans many beams and is still cleared."""
    r = np.array(ranges, dtype=np.float64)
    ret = np.isfinite(r) & (r >= range_min) & (r < range_max)
    none = ~ret & ~np.isnan(r) & ~(r < range_min)
    n = r.size
    idx = np.flatnonzero(none)
    if idx.size == 0 or n < 3:
        return r
    # runs of consecutive no-return beams
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]]
    for a, b in zip(starts, ends, strict=True):
        if b - a + 1 > run:
            continue
        left, right = a - 1, b + 1
        if not wrap and (left < 0 or right >= n):
            continue
        if ret[left % n] and ret[right % n]:
            r[a:b + 1] = np.nan
    return r

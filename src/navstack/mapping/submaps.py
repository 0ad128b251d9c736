"""Submaps: consecutive graph nodes rendered together, the targets of loop closure.

Karto / slam_toolbox match a loop candidate against a *chain* of single scans found near
the current pose; Cartographer (Hess et al., ICRA 2016) matches against *submaps*, local
maps built from many consecutive scans.  A submap shows a place from several viewpoints
(a doorway, the corridor behind it, the room on the other side), so a scan that sees the
place from a new direction still finds a unique fit, and the map can be precomputed once
for the branch-and-bound search (:mod:`navstack.mapping.fast_matcher`) instead of being
rasterised for every attempt.

Here a submap is ``size`` consecutive nodes.  Its frame is the frame of its *anchor*, the
middle node: the scans are drawn at their poses relative to the anchor, so a loop closure
found in the submap is directly the edge ``anchor -> current node``.  The drawing is
redone only when loop closures bend the submap itself (a member moved by more than a
quarter cell relative to the anchor); precomputed grids -- at the loop search resolution
and four times coarser, for wide windows -- are kept for the ``cache_size`` most recently
used submaps.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import se2_between
from navstack.mapping.fast_matcher import PrecomputedGrids

FloatArray = NDArray[np.float64]

__all__ = ["COARSE_FACTOR", "ScanFeatures", "Submap", "SubmapPoints", "Submaps"]

#: the coarse grids of a submap (wide loop windows) are this many times coarser
COARSE_FACTOR = 4


class ScanFeatures(Protocol):
    """What a submap draws of a node: its points, line normals and line mask (robot
    frame; :class:`navstack.mapping.slam.ScanNode`)."""

    points: FloatArray
    normals: FloatArray
    line_like: NDArray[np.bool_]


@dataclass(frozen=True)
class SubmapPoints:
    """A submap's scan points, line normals and line masks in its anchor frame, with
    the members' poses relative to the anchor they were drawn at."""

    points: FloatArray
    normals: FloatArray
    line_like: NDArray[np.bool_]
    relative: FloatArray


@dataclass
class Submap:
    """``nodes`` (consecutive ids) and the anchor node (the middle one)."""

    index: int
    nodes: list[int] = field(default_factory=list)

    @property
    def anchor(self) -> int:
        return self.nodes[len(self.nodes) // 2]


class Submaps:
    """Groups nodes into submaps of ``size`` and caches their drawings and grids."""

    def __init__(self, size: int, resolution: float, smear_deviation: float,
                 depth: int = 6, cache_size: int = 16) -> None:
        self.size = max(1, int(size))
        self.resolution = float(resolution)
        self.smear = float(smear_deviation)
        self.depth = int(depth)
        self.cache_size = max(1, int(cache_size))
        self.all: list[Submap] = []
        self._points: dict[int, SubmapPoints] = {}
        self._grids: OrderedDict[tuple[int, bool], tuple[FloatArray, PrecomputedGrids]] = \
            OrderedDict()

    def add(self, node_id: int) -> None:
        """Append a node (ids must come in increasing order)."""
        if not self.all or len(self.all[-1].nodes) >= self.size:
            self.all.append(Submap(len(self.all)))
        self.all[-1].nodes.append(int(node_id))

    def complete(self) -> list[Submap]:
        """The submaps that reached ``size`` nodes."""
        return [s for s in self.all if len(s.nodes) >= self.size]

    def of_node(self, node_id: int) -> int:
        """Index of the submap holding ``node_id``."""
        return int(node_id) // self.size

    def points(self, submap: Submap, poses: FloatArray,
               scans: Sequence[ScanFeatures]) -> SubmapPoints:
        """The submap drawn in its anchor frame; ``scans[k]`` is node ``k``, ``poses``
        all node poses."""
        relative = se2_between(poses[submap.anchor], poses[submap.nodes])
        cached = self._points.get(submap.index)
        if cached is not None and _same_shape(cached.relative, relative, self.resolution):
            return cached
        pts, nrm, msk = [], [], []
        for node, rel in zip(submap.nodes, relative, strict=True):
            scan = scans[node]
            c, s = math.cos(rel[2]), math.sin(rel[2])
            rot = np.array([[c, s], [-s, c]])
            pts.append(scan.points @ rot + rel[:2])
            nrm.append(scan.normals @ rot)
            msk.append(scan.line_like)
        drawn = SubmapPoints(np.vstack(pts), np.vstack(nrm), np.concatenate(msk), relative)
        self._points[submap.index] = drawn
        for coarse in (False, True):
            self._grids.pop((submap.index, coarse), None)
        return drawn

    def grids(self, submap: Submap, drawn: SubmapPoints,
              coarse: bool = False) -> PrecomputedGrids:
        """Precomputed grids of the drawn submap (cached, least recently used dropped);
        ``coarse``: at four times the resolution (smear at least half a cell) for wide
        windows."""
        key = (submap.index, coarse)
        hit = self._grids.get(key)
        if hit is not None and hit[0] is drawn.relative:
            self._grids.move_to_end(key)
            return hit[1]
        res = self.resolution * (COARSE_FACTOR if coarse else 1)
        smear = max(self.smear, 0.5 * res) if coarse else self.smear
        grids = PrecomputedGrids(drawn.points, res, smear, self.depth)
        self._grids[key] = (drawn.relative, grids)
        while len(self._grids) > self.cache_size:
            self._grids.popitem(last=False)
        return grids

    def forget_drawings(self) -> None:
        """Drop every cached drawing and grid (after the scans were replaced)."""
        self._points.clear()
        self._grids.clear()


def _same_shape(a: FloatArray, b: FloatArray, resolution: float) -> bool:
    """Members within a quarter cell (and the matching angle at 10 m) of where they were
    drawn: the drawing is still good."""
    if a.shape != b.shape:
        return False
    d = se2_between(a, b)
    return bool(np.all(np.hypot(d[:, 0], d[:, 1]) <= 0.25 * resolution)
                and np.all(np.abs(d[:, 2]) <= 0.025 * resolution))

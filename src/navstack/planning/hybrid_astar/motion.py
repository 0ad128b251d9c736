"""Hybrid-A* motion primitives (Nav2 ``HybridMotionTable::initDubin / initReedsShepp``).

Each primitive is an arc of the minimum turning radius (or a straight) whose chord is
at least ``sqrt(2)`` cells, so every expansion leaves its cell, and whose heading change
is a whole number of angle bins, so the search lattice stays on bin headings:

    angle      = 2 asin(sqrt(2) / (2 R))          (chord sqrt(2) on the circle of radius R)
    increments = max(1, ceil(angle / bin_size))   (round up to whole bins)
    dx, dy     = R sin(a), R (1 - cos(a))         (a = increments * bin_size)

DUBIN has 3 primitives (straight, left, right), REEDS_SHEPP 6 (plus their reverses);
with ``allow_primitive_interpolation`` the turns of 1 .. increments-1 bins are added on
the circle through the same chord (radius ``chord / (2 sin(a_n / 2))`` >= R).  The travel
cost of a turn is its arc length, of a straight its chord (Nav2 ``travel_costs``).

For collision checking every primitive also carries sample poses along its arc at most
:data:`~navstack.planning.hybrid_astar.collision.SAMPLE_STEP` cells and
:data:`~navstack.planning.hybrid_astar.collision.HEADING_STEP` bins apart (the end pose
is the last sample), precomputed for each start bin like Nav2's ``delta_xs/delta_ys``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from navstack.planning.hybrid_astar.collision import HEADING_STEP, SAMPLE_STEP

# Nav2 TurnDirection values
FORWARD, LEFT, RIGHT, REVERSE, REV_LEFT, REV_RIGHT = 1, 2, 3, 4, 5, 6


@dataclass(frozen=True)
class MotionTable:
    """Primitives for one (radius, bins, model) in grid cells.

    ``dx[p, b], dy[p, b]``: displacement of primitive ``p`` from a pose of bin ``b``;
    ``dbin[p]``: heading change in bins; ``turn[p]``: Nav2 TurnDirection;
    ``reverse[p]``: the primitive drives backwards;
    ``travel[p]``: travel length [cells]; ``samples[p, b, k] = (dx, dy, bin)`` and
    ``n_samples[p]``: collision samples (the last one is the end pose).
    """

    dx: NDArray[np.float64]
    dy: NDArray[np.float64]
    dbin: NDArray[np.int64]
    turn: NDArray[np.int64]
    reverse: NDArray[np.bool_]
    travel: NDArray[np.float64]
    samples: NDArray[np.float64]
    n_samples: NDArray[np.int64]
    bin_size: float
    increments: int
    chord: float

    @property
    def size(self) -> int:
        return len(self.dbin)


def _primitives(radius: float, bins: int, reeds_shepp: bool,
                interpolate: bool) -> tuple[list[tuple[float, float, int, int]], int, float]:
    """``[(x, y, dbin, turn)]`` in the robot frame, plus ``increments`` and the chord."""
    bin_size = 2.0 * math.pi / bins
    angle = 2.0 * math.asin(min(1.0, math.sqrt(2.0) / (2.0 * radius)))
    increments = 1 if angle < bin_size else math.ceil(angle / bin_size - 1e-12)
    angle = increments * bin_size
    dx = radius * math.sin(angle)
    dy = radius - radius * math.cos(angle)
    chord = math.hypot(dx, dy)
    prims = [(chord, 0.0, 0, FORWARD), (dx, dy, increments, LEFT), (dx, -dy, -increments, RIGHT)]
    if reeds_shepp:
        prims += [(-chord, 0.0, 0, REVERSE), (-dx, dy, -increments, REV_LEFT),
                  (-dx, -dy, increments, REV_RIGHT)]
    if interpolate and increments > 1:
        for i in range(1, increments):
            a_n = i * bin_size
            r_n = chord / (2.0 * math.sin(a_n / 2.0))
            x_n = r_n * math.sin(a_n)
            y_n = r_n - r_n * math.cos(a_n)
            prims += [(x_n, y_n, i, LEFT), (x_n, -y_n, -i, RIGHT)]
            if reeds_shepp:
                prims += [(-x_n, y_n, -i, REV_LEFT), (-x_n, -y_n, i, REV_RIGHT)]
    return prims, increments, chord


def _local_pose(x: float, y: float, dbin: int, turn: int, bin_size: float,
                s: float) -> tuple[float, float, float]:
    """Pose at fraction ``s`` of a primitive, in the frame of its start pose."""
    if dbin == 0:
        return s * x, s * y, 0.0
    psi = s * dbin * bin_size
    # signed curvature w.r.t. signed displacement: + for LEFT / REV_LEFT
    total = dbin * bin_size
    r = abs(x / math.sin(total)) if abs(math.sin(total)) > 1e-12 else abs(y) / 2.0
    kappa = 1.0 / r if turn in (LEFT, REV_LEFT) else -1.0 / r
    return math.sin(psi) / kappa, (1.0 - math.cos(psi)) / kappa, psi


def build_motion_table(radius_cells: float, bins: int, reeds_shepp: bool,
                       interpolate: bool) -> MotionTable:
    """The primitive table of Nav2's Hybrid-A* for a radius in cells."""
    prims, increments, chord = _primitives(radius_cells, bins, reeds_shepp, interpolate)
    bin_size = 2.0 * math.pi / bins
    n_p = len(prims)
    heads = np.arange(bins) * bin_size
    cos_h, sin_h = np.cos(heads), np.sin(heads)
    dx = np.empty((n_p, bins))
    dy = np.empty((n_p, bins))
    dbin = np.array([p[2] for p in prims], dtype=np.int64)
    turn = np.array([p[3] for p in prims], dtype=np.int64)
    travel = np.empty(n_p)
    n_samples = np.empty(n_p, dtype=np.int64)
    local: list[list[tuple[float, float, float]]] = []
    for i, (x, y, db, td) in enumerate(prims):
        dx[i] = x * cos_h - y * sin_h
        dy[i] = x * sin_h + y * cos_h
        if db == 0:
            travel[i] = chord
        else:
            arc = abs(db) * bin_size
            travel[i] = chord / (2.0 * math.sin(arc / 2.0)) * arc
        k = max(math.ceil(travel[i] / SAMPLE_STEP - 1e-9),
                math.ceil(abs(db) / HEADING_STEP - 1e-9), 1)
        n_samples[i] = k
        local.append([_local_pose(x, y, db, td, bin_size, j / k) for j in range(1, k + 1)])
    k_max = int(n_samples.max())
    samples = np.zeros((n_p, bins, k_max, 3))
    for i in range(n_p):
        for j, (lx, ly, lpsi) in enumerate(local[i]):
            samples[i, :, j, 0] = lx * cos_h - ly * sin_h
            samples[i, :, j, 1] = lx * sin_h + ly * cos_h
            samples[i, :, j, 2] = np.round(np.arange(bins) + lpsi / bin_size) % bins
        # the end sample is exactly the primitive's displacement (no rounding drift)
        samples[i, :, n_samples[i] - 1, 0] = dx[i]
        samples[i, :, n_samples[i] - 1, 1] = dy[i]
        samples[i, :, n_samples[i] - 1, 2] = (np.arange(bins) + dbin[i]) % bins
    reverse = np.isin(turn, (REVERSE, REV_LEFT, REV_RIGHT))
    return MotionTable(dx, dy, dbin, turn, reverse, travel, samples, n_samples, bin_size,
                       increments, chord)

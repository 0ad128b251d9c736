"""Analytic expansions: Dubins / Reeds-Shepp shots to the goal during the search.

Nav2 ``AnalyticExpansion``: every few expansions (``analytic_expansion_ratio``) the
search tries to connect the expanded node to the goal with the shortest Dubins /
Reeds-Shepp curve (here: up to :data:`RS_CANDIDATES` Reeds-Shepp curves, shortest
first, the first free one taken).  The shot is accepted when it is between ``sqrt(2)``
cells and ``analytic_expansion_max_length`` long, every sample along it is
collision-free, and its cost profile passes the ``analytic_expansion_max_cost`` rule
(a cost above the limit is allowed only on the final approach into the goal, unless the
shot is shorter than ``2 pi R`` and ``analytic_expansion_max_cost_override`` is set).
An accepted shot is then refined like Nav2's ``refineAnalyticPath``: start it up to
8 x 5 parents earlier while that keeps it valid without more direction changes, then
try radii from ``R`` up to ``4 R`` in half-cell steps, keeping the best-scoring one
(``sum(step * (1 + cost_penalty * cost / 252))``).

Samples are taken every :data:`~navstack.planning.hybrid_astar.collision.SAMPLE_STEP`
cells and :data:`~navstack.planning.hybrid_astar.collision.HEADING_STEP` bins and at
every segment end (cusps included), so the conservative footprint sets cover the curve
between samples as well.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.planning.hybrid_astar.collision import HEADING_STEP, pose_check
from navstack.planning.hybrid_astar.curves import NOP, REEDS_SHEPP, sample_path, shortest_path

RS_CANDIDATES = 8
"""Reeds-Shepp curves a shot tries, shortest first, while they fit the max length.

Nav2 tries only the shortest curve.  Near a goal that needs a manoeuvre between
obstacles the shortest curve often clips one while a slightly longer word (another
cusp, the other turning direction) is free; ending the search there instead of
expanding every state whose cost is within the heuristic's gap took the 95th
percentile on the benchmark's 147k map from 27 to 13 ms (docs/hybrid_astar.md)."""


@nb.njit(cache=True)
def shot(x0: float, y0: float, th0: float, gx: float, gy: float, gth: float, model: int,
         radius: float, max_length: float, max_cost: float, override: bool,
         min_radius: float, step: float, bins: int, data: NDArray[np.uint8],
         off_x: NDArray[np.int16], off_y: NDArray[np.int16], starts: NDArray[np.int64],
         border: int, possible_cost: int, allow_unknown: bool, out: NDArray[np.float64],
         odir: NDArray[np.int8], ocost: NDArray[np.int64]) -> tuple[int, int]:
    """One analytic shot from ``(x0, y0, th0)`` to the goal with ``radius`` [cells].

    Returns ``(samples, direction_changes)``; ``samples = -1`` when the shot is rejected.
    """
    if math.hypot(gx - x0, gy - y0) > max_length:
        return -1, 0  # no curve is shorter than the straight line: skip solving for it
    types = np.empty(5, dtype=np.int64)
    lengths = np.empty(5)
    bin_size = 2.0 * math.pi / bins
    d = -1.0
    for _cand in range(RS_CANDIDATES if model == REEDS_SHEPP else 1):
        d = shortest_path(model, x0, y0, th0, gx, gy, gth, radius, types, lengths, d)
        if not d <= max_length:
            return -1, 0
        if d < math.sqrt(2.0):
            continue
        n = sample_path(x0, y0, th0, types, lengths, radius, step, out, odir,
                        HEADING_STEP * bin_size)
        if n < 0:
            return -1, 0
        worst = 0
        for k in range(n):
            b = round(out[k, 2] / bin_size) % bins
            c = pose_check(data, out[k, 0], out[k, 1], b, off_x, off_y, starts, border,
                           possible_cost, allow_unknown)
            if c < 0:
                worst = -1
                break
            ocost[k] = c
            worst = max(worst, c)
        if worst >= 0:
            break
    else:
        return -1, 0
    if worst > max_cost:
        # high cost is only allowed on the final approach: scanning back from the goal,
        # once a sample is below the limit no earlier one may exceed it
        exited = False
        fail = False
        for k in range(n - 1, -1, -1):
            if ocost[k] <= max_cost:
                exited = True
            elif exited:
                fail = True
                break
        if fail and not (override and d < 2.0 * math.pi * min_radius):
            return -1, 0
    # forward/reverse switches along the shot (Nav2 countDirectionChanges)
    changes = 0
    last = 0
    for i in range(5):
        if types[i] == NOP or lengths[i] == 0.0:
            continue
        cur = 1 if lengths[i] > 0.0 else -1
        if last != 0 and cur != last:
            changes += 1
        last = cur
    return n, changes


@nb.njit(cache=True)
def refine(u: int, nodes: NDArray[np.float64], gx: float, gy: float,
           gth: float, model: int, radius: float, max_length: float, max_cost: float,
           override: bool, cost_penalty: float, step: float, bins: int,
           data: NDArray[np.uint8], off_x: NDArray[np.int16], off_y: NDArray[np.int16],
           starts: NDArray[np.int64], border: int, possible_cost: int, allow_unknown: bool,
           best: NDArray[np.float64], bdir: NDArray[np.int8], bcost: NDArray[np.int64],
           scr: NDArray[np.float64], sdir: NDArray[np.int8],
           scost: NDArray[np.int64]) -> tuple[int, int]:
    """Try and refine an analytic expansion from node ``u``.

    ``nodes`` rows are ``(x, y, theta, g, h, parent, ...)`` (:mod:`.search`).
    Returns ``(samples, from_node)``: the accepted shot (in ``best``/``bdir``) starts at
    node ``from_node``; ``samples = -1`` when no shot from ``u`` is valid.

    One loop with a single call of :func:`shot` (phase 0: from ``u``; phase 1: up to 8
    times 5 parents earlier; phase 2: radii ``R + 0.5 .. 4 R``): numba compiles each call
    site separately, so this keeps the kernel's compile time down.
    """
    n, dc, node = -1, 0, u
    original = math.inf
    best_score = math.inf
    phase = 0
    test = u
    backs = 0
    r = radius
    while True:
        # choose the next attempt (start node, radius), or stop
        if phase == 1:
            if backs >= 8:
                phase = 2
            else:
                t = test
                ok = True
                for _j in range(5):
                    if nodes[t, 5] < 0.0:
                        ok = False
                        break
                    t = int(nodes[t, 5])
                if not ok:
                    phase = 2
                else:
                    test = t
                    backs += 1
        if phase == 2:
            if original == math.inf:
                # Nav2's refinement score: sum(step * (1 + cost_penalty * cost / 252))
                original = 0.0
                px, py = nodes[node, 0], nodes[node, 1]
                for i in range(n):
                    original += math.hypot(best[i, 0] - px, best[i, 1] - py) * (
                        1.0 + cost_penalty * bcost[i] / 252.0)
                    px, py = best[i, 0], best[i, 1]
                if n < 2:
                    original = math.inf
                best_score = original
            if r >= 4.0 * radius:
                break
            r += 0.5
        start = u if phase == 0 else (test if phase == 1 else node)
        rr = radius if phase < 2 else r
        k, dk = shot(nodes[start, 0], nodes[start, 1], nodes[start, 2], gx, gy, gth, model,
                     rr, max_length, max_cost, override, radius, step, bins, data, off_x,
                     off_y, starts, border, possible_cost, allow_unknown, scr, sdir, scost)
        take = False
        if phase == 0:
            if k < 0:
                return -1, u
            take = True
            phase = 1
        elif phase == 1:
            if k < 0:
                phase = 2
            elif dk <= dc:
                take = True
        elif k >= 2:
            sc = 0.0
            px, py = nodes[start, 0], nodes[start, 1]
            for i in range(k):
                sc += math.hypot(scr[i, 0] - px, scr[i, 1] - py) * (
                    1.0 + cost_penalty * scost[i] / 252.0)
                px, py = scr[i, 0], scr[i, 1]
            if (sc <= best_score and dk <= dc) or (sc <= original and dk < dc):
                take = True
                best_score = sc
        if take:
            for i in range(k):
                best[i, 0] = scr[i, 0]
                best[i, 1] = scr[i, 1]
                best[i, 2] = scr[i, 2]
                bdir[i] = sdir[i]
                bcost[i] = scost[i]
            n, dc, node = k, dk, start
    return n, node

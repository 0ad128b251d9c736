"""The Hybrid-A* search kernel (Nav2 ``AStarAlgorithm<NodeHybrid>::createPath``), numba.

State space: cells x angle bins.  A node is created the first time a primitive lands in
its (cell, bin) and keeps the continuous pose that reached it most cheaply, so every
parent -> child step of the final path is exactly one motion primitive (the lattice
guarantee: curvature never exceeds ``1 / minimum_turning_radius``).

Storage is allocated once per planner and grown on demand (the kernel returns
:data:`GROW` and the caller enlarges the arrays):

* nodes: one 64-byte row per node (a single cache line: the search is memory bound;
  rows are indexed in place, never taken as views, whose reference counting costs more
  than the search step)
  holding pose ``x, y`` [cells, continuous], heading ``th`` [rad], cost-so-far ``g``,
  heuristic ``h``, parent, bin and a packed ``meta`` = primitive + 1, centre cost
  (x 64) and the closed flag (x 16384);
* (cell, bin) -> node: a per-cell block of ``bins`` node ids (``-1`` none, ``-2 - id``
  once closed) allocated the first time a cell is touched, found through
  ``cells[cell] = (stamp, block)`` where the stamp is a per-search generation number,
  so nothing of map size is cleared between plans;
* open list: a 4-ary heap of ``(f, node)`` (half the levels of a binary heap, the four
  children in one cache line) with lazy deletion (a node is queued again
  when its cost improves and skipped once closed), as Nav2's priority queue.

Traversal cost (Nav2 ``NodeHybrid::getTraversalCost``)::

    travel * (1 - retrospective_penalty + cost_penalty * cost / 252)   [(cost / 252)^2 with
                                                              use_quadratic_cost_penalty]
        * non_straight_penalty                    turning the same way as the parent
        * (non_straight_penalty + change_penalty) turning the other way
        * reverse_penalty                         reverse primitives

and the heuristic is ``max(obstacle, distance)`` (:mod:`.heuristics`).  The analytic
expansion cadence, goal test, tolerance and on-approach rules follow ``createPath``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
)
from navstack.planning.hybrid_astar.analytic import RS_CANDIDATES, refine
from navstack.planning.hybrid_astar.collision import HEADING_STEP, SUBCELLS, set_index
from navstack.planning.hybrid_astar.curves import REEDS_SHEPP, sample_path, shortest_path
from navstack.planning.hybrid_astar.heuristics import distance_entry, obstacle_expand

RUNNING, FOUND, FOUND_ANALYTIC, FOUND_APPROACH, EXHAUSTED, GROW = range(6)

# node row layout
N_X, N_Y, N_TH, N_G, N_H, N_PAR, N_BIN, N_META = range(8)
NODE_COLS = 8
CLOSED = 16384
# istate layout
(I_NODES, I_HEAP, I_BLOCKS, I_GEN, I_ITER, I_APPROACH, I_COUNTER, I_CLOSEST, I_BEST,
 I_RESULT, I_ANA_N, I_ANA_NODE) = range(12)
N_ISTATE = 12
F_BEST_H, F_H0 = 0, 1
N_FSTATE = 2
# ip (integer parameters) layout
(IP_MODEL, IP_ALLOW_UNKNOWN, IP_POSSIBLE, IP_BORDER, IP_GOAL_CELL, IP_GOAL_BIN,
 IP_MAX_APPROACH, IP_OVERRIDE, IP_FLOORED, IP_WD, IP_DOWN, IP_BINS, IP_QUAD, IP_SWEEP_COST,
 IP_SWEEP_BORDER, IP_MID_COST) = range(16)
N_IP = 16
# fp (float parameters) layout
(FP_REWARD, FP_COST_PEN, FP_NSP, FP_CHP, FP_REVP, FP_RATIO, FP_MAXLEN, FP_MAXCOST, FP_TOL,
 FP_RADIUS, FP_GX, FP_GY, FP_GTH, FP_STEP) = range(14)
N_FP = 14


@nb.njit(cache=True)
def search_run(max_expansions: int, start: NDArray[np.float64], data: NDArray[np.uint8],
               ip: NDArray[np.int64], fp: NDArray[np.float64], mdx: NDArray[np.float64],
               mdy: NDArray[np.float64], mdbin: NDArray[np.int64], mturn: NDArray[np.int64],
               mrev: NDArray[np.bool_], mtravel: NDArray[np.float64],
               msamp: NDArray[np.float64], mnsamp: NDArray[np.int64],
               off_x: NDArray[np.int16], off_y: NDArray[np.int16], starts: NDArray[np.int64],
               hweight: NDArray[np.float64], hdist: NDArray[np.float64],
               hstamp: NDArray[np.int32], hkey: NDArray[np.float64],
               hnode: NDArray[np.int32], hpos: NDArray[np.int32], hstate: NDArray[np.int64],
               table: NDArray[np.float32], nodes: NDArray[np.float64],
               cells: NDArray[np.int32], blocks: NDArray[np.int32],
               block_h: NDArray[np.float64], hk: NDArray[np.float64],
               hn: NDArray[np.int32], abest: NDArray[np.float64], adir: NDArray[np.int8],
               acost: NDArray[np.int64], ascr: NDArray[np.float64], asdir: NDArray[np.int8],
               ascost: NDArray[np.int64], istate: NDArray[np.int64],
               fstate: NDArray[np.float64]) -> int:
    """Expand up to ``max_expansions`` nodes; returns a status code.

    With ``max_expansions == 0`` it starts a new search instead: the start node
    ``start = (x, y, theta, bin)`` is queued and its heuristic stored in
    ``fstate[F_H0]`` (``inf``: the goal cannot be reached even by a point robot).

    RUNNING: budget used, call again; FOUND: the goal node was expanded
    (``istate[I_RESULT]``); FOUND_ANALYTIC: a shot from ``istate[I_ANA_NODE]`` reached
    the goal (``istate[I_ANA_N]`` samples in ``abest``/``adir``); FOUND_APPROACH: the
    best node within tolerance after ``max_on_approach_iterations``; EXHAUSTED: the open
    list is empty; GROW: enlarge the node / heap / block arrays and call again.

    One function on purpose: numba compiles every jitted callee on its own, and the
    helpers below are closures inlined at their call sites.
    """
    h_map, w = data.shape
    bins = ip[IP_BINS]
    n_prim = mdbin.shape[0]
    allow_unknown = ip[IP_ALLOW_UNKNOWN] != 0
    possible = ip[IP_POSSIBLE]
    border = ip[IP_BORDER]
    sweep_cost = ip[IP_SWEEP_COST]
    sweep_border = ip[IP_SWEEP_BORDER]
    mid_cost = ip[IP_MID_COST]
    goal_cell = ip[IP_GOAL_CELL]
    goal_bin = ip[IP_GOAL_BIN]
    reward, cpen = fp[FP_REWARD], fp[FP_COST_PEN]
    nsp, chp, revp = fp[FP_NSP], fp[FP_CHP], fp[FP_REVP]
    ratio = fp[FP_RATIO]
    tol = fp[FP_TOL]
    gx, gy, gth = fp[FP_GX], fp[FP_GY], fp[FP_GTH]
    cos_g, sin_g = math.cos(gth), math.sin(gth)
    bin_size = 2.0 * math.pi / bins
    gen = istate[I_GEN]
    nn = istate[I_NODES]
    size = istate[I_HEAP]
    nblk = istate[I_BLOCKS]
    counter = istate[I_COUNTER]
    closest = istate[I_CLOSEST]
    approach = istate[I_APPROACH]
    best = istate[I_BEST]
    best_h = fstate[F_BEST_H]
    cap_nodes = nodes.shape[0]
    cap_heap = hk.shape[0]
    cap_blocks = blocks.shape[0]
    ceil_ratio = math.ceil(ratio)
    quad = ip[IP_QUAD] != 0
    down = ip[IP_DOWN]
    wd = ip[IP_WD]
    hd = hweight.shape[0] // wd
    floored = ip[IP_FLOORED]
    model = ip[IP_MODEL]
    radius = fp[FP_RADIUS]

    # Helpers are closures over the kernel's arrays: a call to a separately compiled
    # function (even one numba inlines) increments and decrements the reference count of
    # every array argument, which cost more than the work of the lookup or the check.
    def obstacle(idx: int) -> float:
        """Obstacle heuristic of coarse cell idx; expands the Dijkstra only when unsettled."""
        if hstamp[idx] == 2 * hstate[0] + 1:
            return hdist[idx]
        return obstacle_expand(idx, hweight, wd, hdist, hstamp, hkey, hnode, hpos, hstate)

    def check(x: float, y: float, b: int) -> int:
        """:func:`~navstack.planning.hybrid_astar.collision.pose_check` of pose (x, y, b).

        A deliberate copy of it (keep the two in step): calling it, even inlined, costs
        the reference counting of its four array arguments on every sample.
        """
        if x < 0.0 or y < 0.0:
            return -1
        cx = int(x)
        cy = int(y)
        if cx >= w or cy >= h_map:
            return -1
        c = int(data[cy, cx])
        if c == NO_INFORMATION:
            if not allow_unknown:
                return -1
        elif c >= INSCRIBED_INFLATED_OBSTACLE:
            return -1
        inside = border <= cx < w - border and border <= cy < h_map - border
        if c < possible and inside:
            return c
        i = set_index(b, min(int((x - cx) * SUBCELLS), SUBCELLS - 1),
                      min(int((y - cy) * SUBCELLS), SUBCELLS - 1))
        for k in range(starts[2 * i], starts[2 * i + 1] if inside else starts[2 * i + 2]):
            x_k = cx + off_x[k]
            y_k = cy + off_y[k]
            if x_k < 0 or y_k < 0 or x_k >= w or y_k >= h_map:
                return -1
            v = data[y_k, x_k]
            if v == LETHAL_OBSTACLE or (v == NO_INFORMATION and not allow_unknown):
                return -1
        return c

    def distance(cx: int, cy: int, b: int) -> float:
        """Dubins/RS length from cell (cx, cy), bin b to the goal, from the lookup table
        (:func:`~navstack.planning.hybrid_astar.heuristics.distance_entry`)."""
        dx, dy = cx + 0.5 - gx, cy + 0.5 - gy
        rx = round(dx * cos_g + dy * sin_g)
        ry = round(-dx * sin_g + dy * cos_g)
        if abs(rx) >= floored or abs(ry) >= floored:
            return 0.0  # outside the window: the obstacle heuristic dominates (Nav2)
        dth = (b - goal_bin) % bins
        th = (bins - dth) % bins if ry < 0 else dth
        xi = int(rx) + floored
        yi = int(abs(ry))
        v = table[xi, yi, th]
        if v < 0.0:
            return distance_entry(table, floored, model, radius, xi, yi, th)
        return float(v)

    rs_types = np.empty(5, dtype=np.int64)
    rs_lengths = np.empty(5)
    dth_step = HEADING_STEP * bin_size

    def shot_may_pass(x: float, y: float, th: float) -> bool:
        """The first test of :func:`~navstack.planning.hybrid_astar.analytic.refine`: one
        of the :data:`RS_CANDIDATES` shortest curves to the goal is short enough and free
        at every sample.  Most shots fail it, and here that costs no call with two dozen
        array arguments."""
        d = -1.0
        for _cand in range(RS_CANDIDATES if model == REEDS_SHEPP else 1):
            d = shortest_path(model, x, y, th, gx, gy, gth, radius, rs_types, rs_lengths, d)
            if not d <= fp[FP_MAXLEN]:
                return False
            if d < math.sqrt(2.0):
                continue
            n = sample_path(x, y, th, rs_types, rs_lengths, radius, fp[FP_STEP], ascr,
                            asdir, dth_step)
            if n < 0:
                return False
            free = True
            for k in range(n):
                if check(ascr[k, 0], ascr[k, 1], round(ascr[k, 2] / bin_size) % bins) < 0:
                    free = False
                    break
            if free:
                return True
        return False

    def obstacle_at(cx: int, cy: int) -> float:
        """Obstacle heuristic of full-grid cell (cx, cy) (``inf``: goal unreachable)."""
        bx, by = cx // down, cy // down
        oh = obstacle(by * wd + bx)
        if oh == math.inf:
            return math.inf
        if down > 1:
            # bilinear interpolation between the coarse cell centres around the node's
            # cell centre, so h does not stay flat over each 2x2 block
            fx = (cx + 0.5) / down - 0.5
            fy = (cy + 0.5) / down - 0.5
            x0 = math.floor(fx)
            y0 = math.floor(fy)
            ax, ay = fx - x0, fy - y0
            acc = 0.0
            wsum = 0.0
            for q in range(4):
                qx, qy = x0 + (q & 1), y0 + (q >> 1)
                wgt = (ax if q & 1 else 1.0 - ax) * (ay if q >> 1 else 1.0 - ay)
                if wgt <= 0.0 or qx < 0 or qy < 0 or qx >= wd or qy >= hd:
                    continue
                hq = obstacle(qy * wd + qx)
                if hq != math.inf:
                    acc += wgt * hq
                    wsum += wgt
            if wsum > 0.0:
                oh = acc / wsum
        return oh * down

    def push(size: int, f: float, node: int) -> int:
        i = size
        while i > 0:
            par = (i - 1) >> 2
            if hk[par] <= f:
                break
            hk[i] = hk[par]
            hn[i] = hn[par]
            i = par
        hk[i] = f
        hn[i] = node
        return size + 1

    if max_expansions == 0:  # start a new search
        gen = istate[I_GEN] + 1
        if gen >= 2**31 - 1:
            for i in range(cells.shape[0]):
                cells[i, 0] = 0
            gen = 1
        for i in range(istate.shape[0]):
            istate[i] = 0
        istate[I_GEN] = gen
        istate[I_CLOSEST] = 2**31 - 1
        istate[I_BEST] = -1
        istate[I_RESULT] = -1
        fstate[F_BEST_H] = math.inf
        sb = int(start[3])
        cx, cy = int(start[0]), int(start[1])
        cells[cy * w + cx, 0] = gen
        cells[cy * w + cx, 1] = 0
        for i in range(bins):
            blocks[0, i] = -1
        blocks[0, sb] = 0
        istate[I_BLOCKS] = 1
        oh0 = obstacle_at(cx, cy)
        block_h[0] = oh0
        h0 = max(oh0, distance(cx, cy, sb))
        nodes[0, N_X] = start[0]
        nodes[0, N_Y] = start[1]
        nodes[0, N_TH] = start[2]
        nodes[0, N_G] = 0.0
        nodes[0, N_H] = h0
        nodes[0, N_PAR] = -1.0
        nodes[0, N_BIN] = sb
        nodes[0, N_META] = 64.0 * data[cy, cx]
        istate[I_NODES] = 1
        istate[I_HEAP] = push(0, h0, 0)
        fstate[F_H0] = h0
        return RUNNING
    expanded = 0
    status = RUNNING
    while expanded < max_expansions:
        if nn + n_prim >= cap_nodes or size + n_prim >= cap_heap or nblk + n_prim >= cap_blocks:
            status = GROW
            break
        if size == 0:
            status = EXHAUSTED
            break
        u = hn[0]  # pop the minimum (lazy deletion: closed nodes are skipped)
        size -= 1
        if size > 0:
            key = hk[size]
            node = hn[size]
            i = 0
            while True:
                first = 4 * i + 1
                if first >= size:
                    break
                c = first
                for j in range(first + 1, min(first + 4, size)):
                    if hk[j] < hk[c]:
                        c = j
                if key <= hk[c]:
                    break
                hk[i] = hk[c]
                hn[i] = hn[c]
                i = c
            hk[i] = key
            hn[i] = node
        meta = int(nodes[u, N_META])
        if meta >= CLOSED:
            continue
        nodes[u, N_META] = meta + CLOSED
        # closed is also marked in the cell's block (-2 - id), so the children loop skips
        # closed nodes without reading their rows (a cache miss per child)
        blocks[cells[int(nodes[u, N_Y]) * w + int(nodes[u, N_X]), 1],
               int(nodes[u, N_BIN])] = -2 - u
        expanded += 1
        # 2.1) analytic expansion at Nav2's cadence
        closest = min(closest, int(nodes[u, N_H]))
        desired = max(int(closest / ratio), ceil_ratio)
        counter = min(counter, desired)
        if counter <= 0:
            counter = desired
            # a shot longer than analytic_expansion_max_length is rejected and no curve is
            # shorter than the straight line: skip the call (and its array arguments)
            if (math.hypot(nodes[u, N_X] - gx, nodes[u, N_Y] - gy) <= fp[FP_MAXLEN]
                    and shot_may_pass(nodes[u, N_X], nodes[u, N_Y], nodes[u, N_TH])):
                n_a, from_node = refine(u, nodes, gx, gy, gth, ip[IP_MODEL], fp[FP_RADIUS],
                                        fp[FP_MAXLEN], fp[FP_MAXCOST], ip[IP_OVERRIDE] != 0,
                                        cpen, fp[FP_STEP], bins, data, off_x, off_y, starts,
                                        border, possible, allow_unknown, abest, adir, acost,
                                        ascr, asdir, ascost)
                if n_a >= 0:
                    istate[I_ANA_N] = n_a
                    istate[I_ANA_NODE] = from_node
                    status = FOUND_ANALYTIC
                    break
        counter -= 1
        # 3) goal test, then tolerance / on-approach
        ux, uy, ub = nodes[u, N_X], nodes[u, N_Y], int(nodes[u, N_BIN])
        ucx, ucy = int(ux), int(uy)
        if ucy * w + ucx == goal_cell and ub == goal_bin:
            istate[I_RESULT] = u
            status = FOUND
            break
        if best_h < tol:
            approach += 1
            if approach >= ip[IP_MAX_APPROACH]:
                istate[I_RESULT] = best
                status = FOUND_APPROACH
                break
        # 4) expand the primitives; when the parent's cell is cheaper than the cost at
        # the reach of every primitive's footprint sweep, no sample can collide
        inner = (sweep_border <= ucx < w - sweep_border
                 and sweep_border <= ucy < h_map - sweep_border)
        sweep_free = inner and int(data[ucy, ucx]) < sweep_cost
        # every sample between the ends lies within half a primitive of one of them: when
        # both end cells are cheaper than the cost at that reach, only the end is checked
        parent_mid = inner and int(data[ucy, ucx]) < mid_cost
        parent_prim = (meta & 63) - 1
        parent_turn = mturn[parent_prim] if parent_prim >= 0 else -1
        gu = nodes[u, N_G]
        for p in range(n_prim):
            cxf = ux + mdx[p, ub]
            cyf = uy + mdy[p, ub]
            if cxf < 0.0 or cyf < 0.0 or cxf >= w or cyf >= h_map:
                continue
            vb = (ub + mdbin[p]) % bins
            vcx, vcy = int(cxf), int(cyf)
            cell = vcy * w + vcx
            v = -1
            if cells[cell, 0] == gen:
                v = blocks[cells[cell, 1], vb]
                if v <= -2:
                    continue  # closed
            # collision along the primitive
            c = int(data[vcy, vcx])
            first = mnsamp[p] - 1 if parent_mid and c < mid_cost else 0
            for k in range(first, 0 if sweep_free else mnsamp[p]):
                c = check(ux + msamp[p, ub, k, 0], uy + msamp[p, ub, k, 1],
                          int(msamp[p, ub, k, 2]))
                if c < 0:
                    break
            if c < 0:
                continue
            turn = mturn[p]
            cn = c / 252.0
            tc = mtravel[p] * (reward + cpen * (cn * cn if quad else cn))
            if mdbin[p] != 0 and parent_prim >= 0:
                tc *= nsp if parent_turn == turn else nsp + chp
            if mrev[p]:
                tc *= revp
            g = gu + tc
            if v < 0:
                # max(obstacle, distance) (Nav2); the obstacle part is kept per cell
                known = cells[cell, 0] == gen
                oh = block_h[cells[cell, 1]] if known else obstacle_at(vcx, vcy)
                if oh == math.inf:
                    continue  # cannot reach the goal even as a point robot
                hv = max(oh, distance(vcx, vcy, vb))
                if not known:
                    cells[cell, 0] = gen
                    cells[cell, 1] = nblk
                    for i in range(bins):
                        blocks[nblk, i] = -1
                    block_h[nblk] = oh
                    nblk += 1
                v = nn
                nn += 1
                blocks[cells[cell, 1], vb] = v
                nodes[v, N_H] = hv
            elif g >= nodes[v, N_G]:
                continue
            nodes[v, N_X] = cxf
            nodes[v, N_Y] = cyf
            nodes[v, N_TH] = vb * bin_size
            nodes[v, N_G] = g
            nodes[v, N_PAR] = u
            nodes[v, N_BIN] = vb
            nodes[v, N_META] = p + 1 + 64 * c
            hv = nodes[v, N_H]
            size = push(size, g + hv, v)
            if hv < best_h:
                best_h = hv
                best = v
    istate[I_NODES] = nn
    istate[I_HEAP] = size
    istate[I_BLOCKS] = nblk
    istate[I_COUNTER] = counter
    istate[I_CLOSEST] = closest
    istate[I_APPROACH] = approach
    istate[I_BEST] = best
    istate[I_ITER] += expanded
    fstate[F_BEST_H] = best_h
    return status


@nb.njit(cache=True)
def backtrace(node: int, nodes: NDArray[np.float64], mrev: NDArray[np.bool_]
              ) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Poses ``(K, 3)`` from the start to ``node`` and the direction (+1/-1) of the motion
    reaching each pose (the start takes its successor's)."""
    count = 1
    n = node
    while nodes[n, N_PAR] >= 0.0:
        n = int(nodes[n, N_PAR])
        count += 1
    out = np.empty((count, 3))
    direction = np.empty(count, dtype=np.int8)
    n = node
    for i in range(count - 1, -1, -1):
        out[i, 0] = nodes[n, N_X]
        out[i, 1] = nodes[n, N_Y]
        out[i, 2] = nodes[n, N_TH]
        prim = (int(nodes[n, N_META]) & 63) - 1
        direction[i] = -1 if prim >= 0 and mrev[prim] else 1
        n = int(nodes[n, N_PAR])
    if count > 1:
        direction[0] = direction[1]
    return out, direction

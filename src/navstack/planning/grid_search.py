"""8-connected A* / Dijkstra over a cost grid, in numba, resumable in chunks.

Cells live in a *padded* flat layout: cell ``(x, y)`` of a ``W x H`` grid has index
``(y + 1) * (W + 2) + (x + 1)``, so the 8 neighbour offsets are constants and never wrap.
Per cell the kernel reads

* ``moves[i]`` (uint8): bit k set when the move in direction k is allowed (E, W, N, S,
  NE, NW, SE, SW for bits 0..7; N is +y).  It already encodes blocked cells, the grid
  border and the corner-cutting rule (:func:`make_moves`), so the inner loop has no
  passability logic at all;
* ``weight[i]`` (float64): traversal weight of entering the cell.  A step costs
  ``step_length * weight`` (step 1 or sqrt(2)) — NavFn's ``COST_NEUTRAL + COST_FACTOR *
  cost`` and Smac 2D's ``1 + cost_travel_multiplier * cost / 252`` both have this form.
  With ``unit=True`` the weights are all 1 (MovingAI octile metric) and never read.

The open list is an indexed 4-ary heap (decrease-key, one entry per cell) whose child
selection is branch-free; the per-cell state (g, parent, heap position, stamp) lives in a
:class:`GridSearchWorkspace` allocated once per grid size.  A generation counter in
``stamp`` marks what the current search touched (``2*gen`` open, ``2*gen + 1`` closed),
so a new search costs O(1) instead of clearing W*H arrays.

The heuristic is the octile distance times ``h_scale`` (the smallest weight, so it stays
admissible and consistent; ``h_scale = 0`` gives Dijkstra), inflated by ``1 + TIE_EPS``
so that among equal-f nodes the one nearer the goal (larger g) wins.  A successor whose
key does not exceed the key just popped is itself a minimum of the open list, so it is
expanded next from a LIFO stack without touching the heap ("immediate expansion", Sun,
Yeoh, Chen & Koenig, "Simple optimization techniques for A*-based search", AAMAS 2009).
Both tricks change the returned cost by at most ``TIE_EPS * h(start)`` plus float noise,
far below the smallest difference between two distinct grid path lengths.  With unit
weights, moves back toward cells the parent already reached more cheaply are skipped
(exact by the triangle inequality; see :func:`search_run`).

The search expands at most ``max_expansions`` cells per call and can be resumed, so the
caller checks cancel requests and time budgets between chunks (Nav2 Smac's
``terminal_checking_interval``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba as nb
import numpy as np
from numpy.typing import NDArray

SQRT2 = math.sqrt(2.0)
TIE_EPS = 1e-9
"""Relative heuristic inflation used only to break f-ties toward larger g."""

RUNNING = 0
"""Status: the expansion budget of this call ran out; call again to continue."""
FOUND = 1
"""Status: the goal cell was expanded; its g-value is final."""
EXHAUSTED = 2
"""Status: the open list emptied; every reachable cell is closed."""

# move bits: (dx, dy) for bit k
MOVE_DX = (1, -1, 0, 0, 1, -1, 1, -1)
MOVE_DY = (0, 0, 1, -1, 1, 1, -1, -1)

# Unit-weight pruning (see search_run): for a cell entered by move k (0..7) from parent p,
# the neighbours that p itself reached at no greater cost; for straight moves two more
# are skipped when p's diagonal toward them was allowed (bit of p -> bit of the cell).
_PRUNE_ALWAYS = (2 | 32 | 128, 1 | 16 | 64, 8 | 64 | 128, 4 | 16 | 32,
                 2 | 8 | 128, 1 | 8 | 64, 2 | 4 | 32, 1 | 4 | 16, 0)
_PRUNE_SRC1 = (16, 32, 16, 64, 0, 0, 0, 0, 0)
_PRUNE_DST1 = (4, 4, 1, 1, 0, 0, 0, 0, 0)
_PRUNE_SRC2 = (64, 128, 32, 128, 0, 0, 0, 0, 0)
_PRUNE_DST2 = (8, 8, 2, 2, 0, 0, 0, 0, 0)

# state vector layout
_GEN, _SIZE, _EXPANSIONS, _START, _GOAL, _GOAL_X, _GOAL_Y = range(7)


@nb.njit(cache=True)
def make_moves(free: NDArray[np.bool_], corner_cutting: bool) -> NDArray[np.uint8]:
    """Allowed-move bitmask for every cell of an ``(H, W)`` passability grid.

    Returns the padded ``(H + 2, W + 2)`` uint8 mask (zero on the border and on blocked
    cells).  Without corner cutting a diagonal move also needs both orthogonal cells it
    passes between to be free (the MovingAI rule).
    """
    h, w = free.shape
    out = np.zeros((h + 2, w + 2), dtype=np.uint8)
    for y in range(h):
        for x in range(w):
            if not free[y, x]:
                continue
            e = x + 1 < w and free[y, x + 1]
            west = x > 0 and free[y, x - 1]
            n = y + 1 < h and free[y + 1, x]
            s = y > 0 and free[y - 1, x]
            ne = x + 1 < w and y + 1 < h and free[y + 1, x + 1]
            nw = x > 0 and y + 1 < h and free[y + 1, x - 1]
            se = x + 1 < w and y > 0 and free[y - 1, x + 1]
            sw = x > 0 and y > 0 and free[y - 1, x - 1]
            if not corner_cutting:
                ne = ne and e and n
                nw = nw and west and n
                se = se and e and s
                sw = sw and west and s
            out[y + 1, x + 1] = (e * 1 + west * 2 + n * 4 + s * 8 + ne * 16 + nw * 32
                                 + se * 64 + sw * 128)
    return out


@nb.njit(cache=True)
def search_begin(start: int, goal: int, width2: int, g: NDArray[np.float64],
                 parent: NDArray[np.int32], stamp: NDArray[np.int32],
                 hkey: NDArray[np.float64], hnode: NDArray[np.int32], hpos: NDArray[np.int32],
                 state: NDArray[np.int64]) -> None:
    """Start a new search from padded cell ``start`` toward ``goal`` (``-1``: no goal)."""
    gen = state[_GEN] + 1
    if 2 * gen + 1 >= 2**31 - 1:  # wrap the generation counter: clear the stamps once
        stamp[:] = 0
        gen = 1
    state[_GEN] = gen
    g[start] = 0.0
    parent[start] = start
    stamp[start] = 2 * gen
    hkey[0] = -1.0  # below every real key: the start's successors go through the heap
    hnode[0] = start
    hpos[start] = 0
    state[_SIZE] = 1
    state[_EXPANSIONS] = 0
    state[_START] = start
    state[_GOAL] = goal
    state[_GOAL_X] = goal % width2 if goal >= 0 else 0
    state[_GOAL_Y] = goal // width2 if goal >= 0 else 0


def direction_table(width2: int) -> NDArray[np.int8]:
    """``table[d + width2 + 1]`` = move index k of the flat offset ``d`` (8: not a move)."""
    table = np.full(2 * width2 + 3, 8, dtype=np.int8)
    for k, (dx, dy) in enumerate(zip(MOVE_DX, MOVE_DY, strict=True)):
        table[dx + dy * width2 + width2 + 1] = k
    return table


@nb.njit(cache=True)
def search_run(moves: NDArray[np.uint8], weight: NDArray[np.float64], unit: bool,
               dir_of: NDArray[np.int8],
               width2: int, h_scale: float, max_expansions: int, g: NDArray[np.float64],
               parent: NDArray[np.int32], stamp: NDArray[np.int32],
               hkey: NDArray[np.float64], hnode: NDArray[np.int32], hpos: NDArray[np.int32],
               stack: NDArray[np.int32], state: NDArray[np.int64]) -> int:
    """Expand up to ``max_expansions`` cells; return RUNNING, FOUND or EXHAUSTED.

    With unit weights a cell's moves back toward cells its parent already reached at no
    greater cost (the triangle inequality of the octile metric) are skipped: they could
    never improve a g-value, so results are identical, with about half the relax steps.

    One function on purpose (the relax step is an inlined closure): numba
    reference-counts every array passed to a called function, and those atomic
    increments would cost more than the search itself.
    """
    open_mark = 2 * state[_GEN]
    closed_mark = open_mark + 1
    size = state[_SIZE]
    goal = state[_GOAL]
    gx = state[_GOAL_X]
    gy = state[_GOAL_Y]
    hs = h_scale * (1.0 + TIE_EPS) if goal >= 0 else 0.0
    inv_w2 = 1.0 / width2
    d1 = SQRT2 - 1.0
    expanded = 0
    status = RUNNING
    nstack = 0
    u = 0
    fu = hkey[0]
    tol = 0.0
    ux = 0
    uy = 0
    gu = 0.0

    def relax(v: int, step: float, dx: int, dy: int, size: int,
              nstack: int) -> tuple[int, int]:
        s = stamp[v]
        if s > open_mark:  # closed
            return size, nstack
        ng = gu + (step if unit else step * weight[v])
        if s == open_mark and (ng >= g[v] or hpos[v] < 0):
            return size, nstack
        g[v] = ng
        parent[v] = u
        f = ng
        if hs > 0.0:
            ax = abs(ux + dx - gx)
            ay = abs(uy + dy - gy)
            f += hs * (ax + d1 * ay if ax > ay else ay + d1 * ax)
        if s < open_mark:
            stamp[v] = open_mark
            if hs > 0.0 and f <= fu + tol:  # a minimum already: expand next, no heap
                hpos[v] = -1
                stack[nstack] = v
                return size, nstack + 1
            i = size
            size += 1
        else:
            i = hpos[v]
        while i > 0:  # sift up
            p = (i - 1) >> 2
            pk = hkey[p]
            if pk <= f:
                break
            pn = hnode[p]
            hkey[i] = pk
            hnode[i] = pn
            hpos[pn] = i
            i = p
        hkey[i] = f
        hnode[i] = v
        hpos[v] = i
        return size, nstack

    while expanded < max_expansions:
        if nstack > 0:
            nstack -= 1
            u = int(stack[nstack])
        else:
            if size == 0:
                status = EXHAUSTED
                break
            u = int(hnode[0])
            fu = hkey[0]
            tol = 1e-9 + 1e-12 * abs(fu)
            size -= 1
            if size > 0:  # sift the last element down from the root
                key = hkey[size]
                node = hnode[size]
                i = 0
                while True:
                    c = 4 * i + 1
                    if c + 3 < size:  # four children: branch-free minimum
                        k0 = hkey[c]
                        k1 = hkey[c + 1]
                        k2 = hkey[c + 2]
                        k3 = hkey[c + 3]
                        a = c + (k1 < k0)
                        ka = min(k0, k1)
                        b = c + 2 + (k3 < k2)
                        kb = min(k2, k3)
                        c = b if kb < ka else a
                        ck = min(ka, kb)
                    else:
                        if c >= size:
                            break
                        ck = hkey[c]
                        for j in range(c + 1, size):
                            if hkey[j] < ck:
                                ck = hkey[j]
                                c = j
                    if key <= ck:
                        break
                    cn = hnode[c]
                    hkey[i] = ck
                    hnode[i] = cn
                    hpos[cn] = i
                    i = c
                hkey[i] = key
                hnode[i] = node
                hpos[node] = i
        stamp[u] = closed_mark
        expanded += 1
        if u == goal:
            status = FOUND
            break
        gu = g[u]
        uy = int((u + 0.5) * inv_w2)  # exact: avoids a 64-bit integer division
        ux = u - uy * width2
        m = moves[u]
        if unit:
            p = parent[u]
            k = dir_of[u - p + width2 + 1]
            mp = moves[p]
            m &= ~(_PRUNE_ALWAYS[k] | (_PRUNE_DST1[k] if mp & _PRUNE_SRC1[k] else 0)
                   | (_PRUNE_DST2[k] if mp & _PRUNE_SRC2[k] else 0))
        if m & 1:
            size, nstack = relax(u + 1, 1.0, 1, 0, size, nstack)
        if m & 2:
            size, nstack = relax(u - 1, 1.0, -1, 0, size, nstack)
        if m & 4:
            size, nstack = relax(u + width2, 1.0, 0, 1, size, nstack)
        if m & 8:
            size, nstack = relax(u - width2, 1.0, 0, -1, size, nstack)
        if m & 16:
            size, nstack = relax(u + width2 + 1, SQRT2, 1, 1, size, nstack)
        if m & 32:
            size, nstack = relax(u + width2 - 1, SQRT2, -1, 1, size, nstack)
        if m & 64:
            size, nstack = relax(u - width2 + 1, SQRT2, 1, -1, size, nstack)
        if m & 128:
            size, nstack = relax(u - width2 - 1, SQRT2, -1, -1, size, nstack)
    # cells left on the stack go back to the heap so a resumed search loses nothing
    while nstack > 0:
        nstack -= 1
        v = stack[nstack]
        f = g[v]
        if hs > 0.0:
            vy = int((v + 0.5) * inv_w2)
            ax = abs(v - vy * width2 - gx)
            ay = abs(vy - gy)
            f += hs * (ax + d1 * ay if ax > ay else ay + d1 * ax)
        i = size
        size += 1
        while i > 0:
            p = (i - 1) >> 2
            pk = hkey[p]
            if pk <= f:
                break
            pn = hnode[p]
            hkey[i] = pk
            hnode[i] = pn
            hpos[pn] = i
            i = p
        hkey[i] = f
        hnode[i] = v
        hpos[v] = i
    state[_SIZE] = size
    state[_EXPANSIONS] += expanded
    return status


@nb.njit(cache=True)
def extract_cells(parent: NDArray[np.int32], start: int, end: int,
                  width2: int) -> NDArray[np.int32]:
    """``(K, 2)`` unpadded (x, y) cells from ``start`` to ``end`` following ``parent``."""
    count = 1
    n = end
    while n != start:
        n = parent[n]
        count += 1
    out = np.empty((count, 2), dtype=np.int32)
    n = end
    for i in range(count - 1, -1, -1):
        y = n // width2
        out[i, 0] = n - y * width2 - 1
        out[i, 1] = y - 1
        n = parent[n]
    return out


class GridSearchWorkspace:
    """Reusable search buffers for a ``width`` x ``height`` grid (cells ``(x, y)``).

    Load a grid with :meth:`load` (free mask + weights), then run any number of searches
    with :meth:`begin` / :meth:`step`; nothing of size W*H is allocated or cleared per
    search.  Not thread-safe: one search at a time.
    """

    def __init__(self, width: int, height: int) -> None:
        if width <= 0 or height <= 0:
            raise ValueError(f"grid size must be positive, got {width}x{height}")
        self.width = width
        self.height = height
        self.width2 = width + 2
        n = (width + 2) * (height + 2)
        self.moves = np.zeros(n, dtype=np.uint8)
        self.weight = np.ones(n, dtype=np.float64)
        self.unit = True
        self.g = np.zeros(n, dtype=np.float64)
        self.parent = np.zeros(n, dtype=np.int32)
        self.stamp = np.zeros(n, dtype=np.int32)
        self.hkey = np.zeros(n, dtype=np.float64)
        self.hnode = np.zeros(n, dtype=np.int32)
        self.hpos = np.zeros(n, dtype=np.int32)
        self.stack = np.zeros(n, dtype=np.int32)
        self.state = np.zeros(7, dtype=np.int64)
        self.dir_of = direction_table(self.width2)

    def load(self, free: NDArray[np.bool_], weight: NDArray[np.float64] | None = None,
             corner_cutting: bool = False) -> None:
        """Set the grid: ``free[H, W]`` passable cells and ``weight[H, W]`` (None: all 1)."""
        if free.shape != (self.height, self.width):
            raise ValueError(f"grid shape {free.shape} != workspace {(self.height, self.width)}")
        free = np.ascontiguousarray(free, dtype=np.bool_)
        self.moves[:] = make_moves(free, corner_cutting).reshape(-1)
        self.unit = weight is None
        if weight is not None:
            self.weight.reshape(self.height + 2, self.width2)[1:-1, 1:-1] = weight

    def index(self, x: int, y: int) -> int:
        """Padded flat index of cell ``(x, y)``."""
        return (y + 1) * self.width2 + (x + 1)

    @property
    def expansions(self) -> int:
        """Cells expanded by the current search so far."""
        return int(self.state[_EXPANSIONS])

    def begin(self, start: tuple[int, int], goal: tuple[int, int] | None) -> None:
        """Start a search from cell ``start`` toward ``goal`` (``None``: expand everything)."""
        s = self.index(*start)
        t = -1 if goal is None else self.index(*goal)
        search_begin(s, t, self.width2, self.g, self.parent, self.stamp, self.hkey,
                     self.hnode, self.hpos, self.state)

    def step(self, h_scale: float, max_expansions: int) -> int:
        """Continue the current search for at most ``max_expansions`` expansions."""
        return int(search_run(self.moves, self.weight, self.unit, self.dir_of, self.width2,
                              h_scale,
                              max_expansions, self.g, self.parent, self.stamp, self.hkey,
                              self.hnode, self.hpos, self.stack, self.state))

    def run(self, h_scale: float, chunk: int,
            between_chunks: Callable[[int], None] | None = None) -> int:
        """Run the current search to FOUND/EXHAUSTED in chunks of ``chunk`` expansions.

        ``between_chunks(expansions)`` is called after every unfinished chunk; it stops
        the search by raising (cancel, timeout, iteration budget).
        """
        while True:
            status = self.step(h_scale, chunk)
            if status != RUNNING:
                return status
            if between_chunks is not None:
                between_chunks(self.expansions)

    def closed_mask(self) -> NDArray[np.bool_]:
        """``(H, W)`` bool: cells closed (final g) by the current search."""
        closed = 2 * int(self.state[_GEN]) + 1
        st = self.stamp.reshape(self.height + 2, self.width2)[1:-1, 1:-1]
        return np.asarray(st == closed)

    def is_closed(self, cell: tuple[int, int]) -> bool:
        return bool(self.stamp[self.index(*cell)] == 2 * int(self.state[_GEN]) + 1)

    def cost_to(self, cell: tuple[int, int]) -> float:
        """g-value of a closed cell (the optimal cost from the start)."""
        return float(self.g[self.index(*cell)])

    def cells_to(self, cell: tuple[int, int]) -> NDArray[np.int32]:
        """``(K, 2)`` (x, y) cells from the start to a closed ``cell``."""
        return extract_cells(self.parent, int(self.state[_START]), self.index(*cell),
                             self.width2)

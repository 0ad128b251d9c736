"""Growable search buffers of the Hybrid-A* kernel (nodes, open list, cell blocks).

Allocated once per planner and reused across plans: the per-search generation stamp in
``cell_stamp`` makes a new search O(1), and the node / heap / block arrays double when
the kernel reports :data:`~navstack.planning.hybrid_astar.search.GROW`.
"""

from __future__ import annotations

from typing import Any, TypeVar, cast

import numpy as np
from numpy.typing import NDArray

from navstack.planning.hybrid_astar.search import N_FSTATE, N_ISTATE, NODE_COLS

ArrayT = TypeVar("ArrayT", bound=NDArray[Any])


def _grow(a: ArrayT, rows: int) -> ArrayT:
    out = np.empty((rows, *a.shape[1:]), dtype=a.dtype)
    out[:len(a)] = a
    return cast(ArrayT, out)


class SearchWorkspace:
    """Buffers for a ``width x height`` grid with ``bins`` headings."""

    def __init__(self, width: int, height: int, bins: int, nodes: int = 1 << 16,
                 analytic_samples: int = 256) -> None:
        self.width, self.height, self.bins = width, height, bins
        self.cells = np.zeros((width * height, 2), dtype=np.int32)
        self.nodes = np.zeros((nodes, NODE_COLS))
        self.hk = np.zeros(2 * nodes)
        self.hn = np.zeros(2 * nodes, dtype=np.int32)
        self.blocks = np.zeros((nodes // 4, bins), dtype=np.int32)
        self.block_h = np.zeros(nodes // 4)  # obstacle heuristic of each block's cell
        self.istate = np.zeros(N_ISTATE, dtype=np.int64)
        self.fstate = np.zeros(N_FSTATE)
        self.abest = np.zeros((0, 3))
        self.set_analytic_capacity(analytic_samples)

    def set_analytic_capacity(self, samples: int) -> None:
        """Room for an analytic shot of ``samples`` poses (best and scratch buffers)."""
        if len(self.abest) >= samples:
            return
        self.abest = np.zeros((samples, 3))
        self.adir = np.zeros(samples, dtype=np.int8)
        self.acost = np.zeros(samples, dtype=np.int64)
        self.ascr = np.zeros((samples, 3))
        self.asdir = np.zeros(samples, dtype=np.int8)
        self.ascost = np.zeros(samples, dtype=np.int64)

    def grow(self) -> None:
        """Double the node, heap and block capacities, keeping their contents."""
        self.nodes = _grow(self.nodes, 2 * len(self.nodes))
        self.hk = _grow(self.hk, 2 * len(self.hk))
        self.hn = _grow(self.hn, 2 * len(self.hn))
        self.blocks = _grow(self.blocks, 2 * len(self.blocks))
        self.block_h = _grow(self.block_h, 2 * len(self.block_h))

    @property
    def nodes_used(self) -> int:
        return int(self.istate[0])

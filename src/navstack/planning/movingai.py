"""MovingAI grid benchmark files and exact octile shortest paths on them.

Format (N. Sturtevant, "Benchmarks for Grid-Based Pathfinding", IEEE TCIAIG 2012;
movingai.com): a ``.map`` file has the header ``type octile`` / ``height H`` /
``width W`` / ``map`` then H rows of W characters, ``.`` ``G`` ``S`` passable and
``@`` ``O`` ``T`` ``W`` blocked; a ``.scen`` file has ``version 1`` then tab-separated
``bucket map width height start_x start_y goal_x goal_y optimal_length`` lines with
(0, 0) the upper-left cell.  Moves are 8-connected, a diagonal costs sqrt(2) and may not
cut a corner (both adjacent orthogonal cells must be passable).

:class:`MovingAISolver` answers queries on one map with the shared numba kernel of
:mod:`navstack.planning.grid_search` in "MovingAI mode" (unit cell weights, no corner
cutting, float64 lengths), reusing one workspace for every query.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import MapFileError
from navstack.planning.grid_search import FOUND, GridSearchWorkspace

PASSABLE_CHARS = frozenset(".GS")
BLOCKED_CHARS = frozenset("@OTW")

@dataclass(frozen=True, slots=True)
class Scenario:
    """One ``.scen`` line: a start/goal query with its published optimal length."""

    bucket: int
    map_name: str
    width: int
    height: int
    start_x: int
    start_y: int
    goal_x: int
    goal_y: int
    optimal_length: float
    optimal_text: str
    """``optimal_length`` as printed in the file (its precision varies by file)."""

    @property
    def print_tolerance(self) -> float:
        """Half a unit in the last printed digit, assuming at least 6 significant digits.

        The dao files print ``%g``-style (6 significant digits: ``1006.71``), newer ones
        fixed 8 decimals; a trailing-zero-free ``%g`` print such as ``1`` is exact to
        6 significant digits, not to 0.5.
        """
        text = self.optimal_text
        decimals = len(text.split(".", 1)[1]) if "." in text else 0
        value = abs(self.optimal_length)
        sig = 5 - math.floor(math.log10(value)) if value > 0 else 5
        return 0.5 * 10.0 ** (-max(decimals, sig))


def load_map(path: str | Path) -> NDArray[np.bool_]:
    """Read a MovingAI ``.map`` file into ``passable[H, W]`` (row 0 = top row)."""
    p = Path(path)
    try:
        lines = p.read_text().splitlines()
    except OSError as exc:
        raise MapFileError(f"{p}: cannot read MovingAI map: {exc.strerror}") from None
    header: dict[str, str] = {}
    i = 0
    while i < len(lines) and lines[i].strip() != "map":
        parts = lines[i].split()
        if len(parts) == 2:
            header[parts[0]] = parts[1]
        i += 1
    if i == len(lines) or "height" not in header or "width" not in header:
        raise MapFileError(f"{p}: not a MovingAI map (needs 'height', 'width' and 'map' lines)")
    h, w = int(header["height"]), int(header["width"])
    rows = lines[i + 1:i + 1 + h]
    if len(rows) != h or any(len(r) < w for r in rows):
        raise MapFileError(f"{p}: expected {h} rows of {w} characters after 'map'")
    chars = np.frombuffer("".join(r[:w] for r in rows).encode("ascii"), dtype=np.uint8)
    passable = np.isin(chars, np.frombuffer(b".GS", dtype=np.uint8))
    return passable.reshape(h, w)


def load_scen(path: str | Path) -> list[Scenario]:
    """Read a MovingAI ``.scen`` file (``version 1``) into a list of scenarios."""
    p = Path(path)
    try:
        lines = p.read_text().splitlines()
    except OSError as exc:
        raise MapFileError(f"{p}: cannot read MovingAI scenario file: {exc.strerror}") from None
    out: list[Scenario] = []
    for n, line in enumerate(lines, start=1):
        if not line.strip() or line.startswith("version"):
            continue
        f = line.split("\t")
        if len(f) != 9:
            raise MapFileError(f"{p}:{n}: expected 9 tab-separated fields, got {len(f)}")
        out.append(Scenario(int(f[0]), f[1], int(f[2]), int(f[3]), int(f[4]), int(f[5]),
                            int(f[6]), int(f[7]), float(f[8]), f[8].strip()))
    return out


class MovingAISolver:
    """Exact octile shortest paths on one passability map, one workspace for all queries."""

    def __init__(self, passable: NDArray[np.bool_]) -> None:
        passable = np.asarray(passable, dtype=bool)
        self.passable = passable
        self.height, self.width = passable.shape
        self.workspace = GridSearchWorkspace(self.width, self.height)
        self.workspace.load(passable, None, corner_cutting=False)

    def solve(self, sx: int, sy: int, gx: int, gy: int,
              with_path: bool = True) -> tuple[float, NDArray[np.int32]]:
        """Shortest path length and ``(K, 2)`` (x, y) cells from (sx, sy) to (gx, gy).

        Returns ``(inf, empty)`` when the goal is unreachable or an end is blocked.
        """
        for x, y in ((sx, sy), (gx, gy)):
            if not (0 <= x < self.width and 0 <= y < self.height) or not self.passable[y, x]:
                return math.inf, np.zeros((0, 2), dtype=np.int32)
        ws = self.workspace
        ws.begin((sx, sy), (gx, gy))
        if ws.step(1.0, 1 << 62) != FOUND:
            return math.inf, np.zeros((0, 2), dtype=np.int32)
        length = ws.cost_to((gx, gy))
        cells = ws.cells_to((gx, gy)) if with_path else np.zeros((0, 2), dtype=np.int32)
        return length, cells


def solve(passable: NDArray[np.bool_], sx: int, sy: int, gx: int, gy: int,
          solver: MovingAISolver | None = None) -> tuple[float, NDArray[np.int32]]:
    """One MovingAI query; pass ``solver`` (built once per map) to reuse its buffers."""
    if solver is None or solver.passable is not passable:
        solver = MovingAISolver(passable)
    return solver.solve(sx, sy, gx, gy)


def path_length(cells: NDArray[np.int32]) -> float:
    """Octile length of a cell path (1 per orthogonal step, sqrt(2) per diagonal)."""
    if len(cells) < 2:
        return 0.0
    d = np.abs(np.diff(cells.astype(np.int64), axis=0))
    return float(np.sum(np.where((d[:, 0] + d[:, 1]) == 2, math.sqrt(2.0), 1.0)))

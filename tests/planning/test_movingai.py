"""MovingAI mode: every arena / den101d scenario solved at its published optimal length."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navstack.core.errors import MapFileError
from navstack.planning.movingai import (
    MovingAISolver,
    Scenario,
    load_map,
    load_scen,
    path_length,
    solve,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "movingai"


def _check_moves(passable: np.ndarray, cells: np.ndarray) -> None:
    """8-connected unit moves through passable cells, never cutting a corner."""
    assert passable[cells[:, 1], cells[:, 0]].all()
    if len(cells) < 2:
        return
    d = np.diff(cells.astype(np.int64), axis=0)
    assert np.abs(d).max() <= 1 and (np.abs(d).sum(axis=1) > 0).all()
    for (x, y), (dx, dy) in zip(cells[:-1], d, strict=True):
        if dx and dy:
            assert passable[y, x + dx] and passable[y + dy, x]


@pytest.mark.parametrize("name", ["arena", "den101d"])
def test_every_scenario_is_optimal(name: str) -> None:
    passable = load_map(DATA / f"{name}.map")
    scens = load_scen(DATA / f"{name}.map.scen")
    solver = MovingAISolver(passable)
    assert len(scens) == {"arena": 160, "den101d": 220}[name]
    for sc in scens:
        length, cells = solver.solve(sc.start_x, sc.start_y, sc.goal_x, sc.goal_y)
        assert abs(length - sc.optimal_length) <= 1e-4, sc
        assert tuple(cells[0]) == (sc.start_x, sc.start_y)
        assert tuple(cells[-1]) == (sc.goal_x, sc.goal_y)
        assert path_length(cells) == pytest.approx(length, abs=1e-9)
        _check_moves(passable, cells)


def test_load_map_and_scen_fields() -> None:
    passable = load_map(DATA / "arena.map")
    assert passable.shape == (49, 49)
    assert not passable[0].any()  # the top row is all trees
    first = load_scen(DATA / "arena.map.scen")[2]
    assert first == Scenario(0, "maps/dao/arena.map", 49, 49, 1, 13, 4, 12, 3.41421, "3.41421")
    assert first.print_tolerance == pytest.approx(5e-6)


def test_print_tolerance_follows_the_printed_precision() -> None:
    def tol(text: str) -> float:
        return Scenario(0, "m", 1, 1, 0, 0, 0, 0, float(text), text).print_tolerance

    assert tol("1006.71") == pytest.approx(0.005)  # %g: 6 significant digits
    assert tol("1") == pytest.approx(5e-6)
    assert tol("852.44069214") == pytest.approx(5e-9)  # fixed 8 decimals


def test_unreachable_and_blocked_queries() -> None:
    passable = np.ones((5, 5), dtype=bool)
    passable[:, 2] = False
    solver = MovingAISolver(passable)
    length, cells = solver.solve(0, 0, 4, 4)
    assert math.isinf(length) and len(cells) == 0
    assert math.isinf(solver.solve(2, 0, 0, 0)[0])  # start blocked
    assert solver.solve(0, 0, 1, 4)[0] == pytest.approx(3 + math.sqrt(2), abs=1e-12)


def test_corner_cutting_is_forbidden() -> None:
    # diagonal from (0,0) to (1,1) squeezes between two blocked cells: must go around
    passable = np.array([[1, 0, 1],
                         [0, 1, 1],
                         [1, 1, 1]], dtype=bool)
    assert math.isinf(MovingAISolver(passable).solve(0, 0, 1, 1)[0])
    passable[0, 1] = True
    length, _ = solve(passable, 0, 0, 1, 1)
    assert length == pytest.approx(2.0)  # (0,0)->(1,0)->(1,1): the diagonal still cuts (0,1)


def test_bad_files_raise_map_file_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.map"
    bad.write_text("type octile\nheight 2\nwidth 3\nmap\n...\n")
    with pytest.raises(MapFileError, match="expected 2 rows of 3 characters"):
        load_map(bad)
    with pytest.raises(MapFileError, match="cannot read MovingAI map"):
        load_map(tmp_path / "missing.map")

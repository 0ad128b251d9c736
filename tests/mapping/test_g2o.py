"""g2o reader/writer: exact parse, bit-exact round trip, edges-only chaining, typed errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navstack.benchmarks.common import SHIPPED_DATA
from navstack.mapping.g2o import (
    G2oFileNotFound,
    G2oFormatError,
    G2oGraph,
    read_g2o,
    write_g2o,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "g2o"
SHIPPED = SHIPPED_DATA / "g2o"


def _write(tmp_path: Path, text: str, name: str = "g.g2o") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _same(a: G2oGraph, b: G2oGraph) -> None:
    for name in ("ids", "poses", "edge_i", "edge_j", "measurements", "information", "fixed"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_reads_vertices_edges_information_and_fix(tmp_path: Path) -> None:
    path = _write(tmp_path, "# a comment\n\nVERTEX_SE2 3 1.5 -2 0.25\nVERTEX_SE2 0 0 0 0\n"
                            "FIX 0\nEDGE_SE2 0 3 1.5 -2 0.25 10 1 2 20 3 30\n")
    g = read_g2o(path)
    np.testing.assert_array_equal(g.ids, [3, 0])
    np.testing.assert_array_equal(g.poses, [[1.5, -2.0, 0.25], [0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(g.edge_i, [0])
    np.testing.assert_array_equal(g.edge_j, [3])
    np.testing.assert_array_equal(g.measurements, [[1.5, -2.0, 0.25]])
    np.testing.assert_array_equal(g.information[0], [[10, 1, 2], [1, 20, 3], [2, 3, 30]])
    np.testing.assert_array_equal(g.fixed, [0])
    assert g.vertices()[3].tolist() == [1.5, -2.0, 0.25]


def test_write_read_round_trip_is_bit_exact(tmp_path: Path) -> None:
    awkward = [0.1 + 0.2, 1e-300, -2.5e17, math.pi, -0.0]
    g = G2oGraph(np.array([0, 7]), np.array([awkward[:3], awkward[2:]]),
                 np.array([0]), np.array([7]), np.array([awkward[1:4]]),
                 np.array([[[1 / 3, 0.1, 0.0], [0.1, 2 / 3, 1e-9], [0.0, 1e-9, 1e6 / 7]]]),
                 np.array([7]))
    write_g2o(g, tmp_path / "a.g2o")
    _same(g, read_g2o(tmp_path / "a.g2o"))
    mit = read_g2o(DATA / "MIT.g2o")
    assert (mit.num_vertices, mit.num_edges) == (808, 827)
    write_g2o(mit, tmp_path / "mit.g2o")
    _same(mit, read_g2o(tmp_path / "mit.g2o"))


def test_edges_only_file_is_chained_from_the_origin(tmp_path: Path) -> None:
    path = _write(tmp_path, "EDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\n"
                            "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
                            "EDGE_SE2 2 0 5 5 1 1 0 0 1 0 1\n")   # loop closure, not used
    g = read_g2o(path)
    np.testing.assert_array_equal(g.ids, [0, 1, 2])
    np.testing.assert_allclose(g.poses, [[0, 0, 0], [1, 0, math.pi / 2], [1, 1, math.pi / 2]],
                               atol=1e-15)


@pytest.mark.parametrize(("text", "line", "reason"), [
    ("VERTEX_SE2 0 0 0\n", 1, "VERTEX_SE2 needs 4 values (id x y theta), got 3"),
    ("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 x 0 1\n", 2,
     "EDGE_SE2 value 9 'x' is not a number"),
    ("VERTEX_SE2 0 0 nan 0\n", 1, "VERTEX_SE2 value 3 'nan' is not finite"),
    ("VERTEX_SE2 1.5 0 0 0\n", 1, "VERTEX_SE2 id 1.5 is not a non-negative integer"),
    ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 1 1\n", 2, "VERTEX_SE2 0 is already defined on line 1"),
    ("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 0 1 0 0 1 0 0 1 0 1\n", 2,
     "EDGE_SE2 joins vertex 0 to itself"),
    ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
     "EDGE_SE2 1 4 1 0 0 1 0 0 1 0 1\n", 4,
     "EDGE_SE2 uses vertex 4, which no VERTEX_SE2 line defines"),
    ("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 3 1 0 0 1 0 0 1 0 1\n", 2,
     "vertex 3 has no VERTEX_SE2 line and no odometry edge 2 -> 3 to initialise it from "
     "(edges-only files are chained i -> i+1)"),
    ("VERTEX_XY 0 1 2\n", 1, "unsupported tag 'VERTEX_XY': only VERTEX_SE2, EDGE_SE2 and "
                             "FIX are read"),
    ("VERTEX_SE2 0 0 0 0\nFIX 5\n", 2, "FIX names vertex 5, which is not defined"),
])
def test_bad_lines_raise_with_file_line_and_reason(tmp_path: Path, text: str, line: int,
                                                   reason: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(G2oFormatError) as info:
        read_g2o(path)
    assert (info.value.line, info.value.reason) == (line, reason)
    assert str(info.value) == f"{path}:{line}: {reason}"


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(G2oFileNotFound) as info:
        read_g2o(tmp_path / "nope.g2o")
    assert str(info.value) == f"g2o file not found: {tmp_path / 'nope.g2o'}"
    assert isinstance(info.value, FileNotFoundError)


def test_csail_edges_only_graph() -> None:
    g = read_g2o(SHIPPED / "CSAIL.g2o")
    assert (g.num_vertices, g.num_edges) == (1045, 1172)
    np.testing.assert_array_equal(g.poses[0], [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(g.poses[1], g.measurements[0])   # EDGE_SE2 0 1 ...

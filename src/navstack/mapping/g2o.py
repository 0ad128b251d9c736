"""g2o text format for 2D pose graphs (Kümmerle et al., "g2o: A General Framework for
Graph Optimization", ICRA 2011): reader and writer.

Lines used::

    VERTEX_SE2 id x y theta
    EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33
    FIX id

An edge is the pose of vertex ``j`` seen from vertex ``i`` (``x_i^-1 * x_j``, gtsam's
``BetweenFactorPose2``) with the upper triangle of its 3x3 information matrix over
``(dx, dy, dtheta)``.  Blank lines and ``#`` comments are skipped; any other tag is an
error (dropping a landmark or 3D constraint silently would change the optimum).

Files with edges only (the public ``CSAIL.g2o``): poses are initialised by chaining the
odometry edges ``i -> i+1`` from the origin at the smallest vertex id.  A vertex that is
neither declared nor reachable that way is an error naming the vertex id and the line of
the first edge that uses it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import NavstackError
from navstack.core.geometry import se2_compose

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
_UPPER = (np.array([0, 0, 0, 1, 1, 2]), np.array([0, 1, 2, 1, 2, 2]))


class G2oError(NavstackError):
    """A g2o file cannot be read or written."""


class G2oFileNotFound(G2oError, FileNotFoundError):
    """The g2o path does not exist."""


class G2oFormatError(G2oError, ValueError):
    """A line of a g2o file is malformed; ``str`` is ``FILE:LINE: reason``."""

    def __init__(self, file: str, line: int, reason: str) -> None:
        self.file, self.line, self.reason = file, line, reason
        super().__init__(f"{file}:{line}: {reason}")


@dataclass(frozen=True, slots=True, eq=False)
class G2oGraph:
    """A 2D pose graph as arrays.

    ``ids`` ``(N,)`` vertex ids in file order with ``poses`` ``(N, 3)`` (x, y, theta);
    ``edge_i``, ``edge_j`` ``(M,)``; ``measurements`` ``(M, 3)`` = pose of ``j`` in the frame
    of ``i``; ``information`` ``(M, 3, 3)`` symmetric; ``fixed`` ids held constant.
    """

    ids: IntArray
    poses: FloatArray
    edge_i: IntArray
    edge_j: IntArray
    measurements: FloatArray
    information: FloatArray
    fixed: IntArray

    @property
    def num_vertices(self) -> int:
        return int(self.ids.size)

    @property
    def num_edges(self) -> int:
        return int(self.edge_i.size)

    def vertices(self) -> dict[int, FloatArray]:
        """Vertex id -> pose ``(3,)``."""
        return {int(i): p for i, p in zip(self.ids, self.poses, strict=True)}


def _numbers(tok: list[str], count: int, kind: str, fields: str, file: str,
             line: int) -> list[float]:
    if len(tok) != count + 1:
        raise G2oFormatError(file, line, f"{kind} needs {count} values ({fields}), "
                                         f"got {len(tok) - 1}")
    out: list[float] = []
    for k, t in enumerate(tok[1:], start=1):
        try:
            v = float(t)
        except ValueError:
            raise G2oFormatError(file, line, f"{kind} value {k} {t!r} is not a number") from None
        if not math.isfinite(v):
            raise G2oFormatError(file, line, f"{kind} value {k} {t!r} is not finite")
        out.append(v)
    return out


def _vertex_id(value: float, kind: str, file: str, line: int) -> int:
    if value != int(value) or value < 0:
        raise G2oFormatError(file, line, f"{kind} id {value!r} is not a non-negative integer")
    return int(value)


def read_g2o(path: str | Path) -> G2oGraph:
    """Read a 2D g2o pose graph; raises :class:`G2oFormatError` (file:line: reason) on
    the first malformed line and :class:`G2oFileNotFound` for a missing file."""
    p = Path(path)
    if not p.is_file():
        if not p.exists():
            raise G2oFileNotFound(f"g2o file not found: {p}")
        raise G2oError(f"g2o path is not a file: {p}")
    name = str(p)
    vertices: dict[int, tuple[float, float, float]] = {}
    vertex_line: dict[int, int] = {}
    e_i: list[int] = []
    e_j: list[int] = []
    meas: list[list[float]] = []
    upper: list[list[float]] = []
    edge_lines: list[int] = []
    fixed: list[int] = []
    fix_lines: list[int] = []
    with p.open("r", encoding="utf-8", errors="replace") as fh:
        for line_no, line in enumerate(fh, start=1):
            tok = line.split()
            if not tok or tok[0].startswith("#"):
                continue
            tag = tok[0]
            if tag == "EDGE_SE2":
                v = _numbers(tok, 11, tag, "i j dx dy dtheta I11 I12 I13 I22 I23 I33",
                             name, line_no)
                i, j = _vertex_id(v[0], tag, name, line_no), _vertex_id(v[1], tag, name,
                                                                         line_no)
                if i == j:
                    raise G2oFormatError(name, line_no, f"EDGE_SE2 joins vertex {i} to itself")
                e_i.append(i)
                e_j.append(j)
                meas.append(v[2:5])
                upper.append(v[5:11])
                edge_lines.append(line_no)
            elif tag == "VERTEX_SE2":
                v = _numbers(tok, 4, tag, "id x y theta", name, line_no)
                vid = _vertex_id(v[0], tag, name, line_no)
                if vid in vertices:
                    raise G2oFormatError(name, line_no, f"VERTEX_SE2 {vid} is already defined "
                                                        f"on line {vertex_line[vid]}")
                vertices[vid] = (v[1], v[2], v[3])
                vertex_line[vid] = line_no
            elif tag == "FIX":
                if len(tok) < 2:
                    raise G2oFormatError(name, line_no, "FIX needs at least one vertex id")
                v = _numbers(tok, len(tok) - 1, tag, "ids", name, line_no)
                fixed.extend(_vertex_id(x, tag, name, line_no) for x in v)
                fix_lines.extend([line_no] * len(v))
            else:
                raise G2oFormatError(name, line_no, f"unsupported tag {tag!r}: only "
                                                    "VERTEX_SE2, EDGE_SE2 and FIX are read")
    ei = np.array(e_i, dtype=np.int64)
    ej = np.array(e_j, dtype=np.int64)
    m = np.array(meas, dtype=np.float64).reshape(-1, 3)
    info = np.zeros((len(upper), 3, 3))
    up = np.array(upper, dtype=np.float64).reshape(-1, 6)
    info[:, _UPPER[0], _UPPER[1]] = up
    info[:, _UPPER[1], _UPPER[0]] = up
    if not vertices and e_i:
        vertices = _chain_odometry(ei, ej, m, edge_lines, name)
    else:
        _check_known(vertices, ei, ej, edge_lines, name)
    for f, f_line in zip(fixed, fix_lines, strict=True):
        if f not in vertices:
            raise G2oFormatError(name, f_line, f"FIX names vertex {f}, which is not defined")
    ids = np.array(list(vertices), dtype=np.int64)
    poses = np.array(list(vertices.values()), dtype=np.float64).reshape(-1, 3)
    return G2oGraph(ids, poses, ei, ej, m, info, np.array(fixed, dtype=np.int64))


def _check_known(vertices: dict[int, tuple[float, float, float]], ei: IntArray,
                 ej: IntArray, lines: list[int], file: str) -> None:
    known = np.array(list(vertices), dtype=np.int64)
    for ends in (ei, ej):
        missing = ~np.isin(ends, known)
        if missing.any():
            k = int(np.argmax(missing))
            raise G2oFormatError(file, lines[k], f"EDGE_SE2 uses vertex {int(ends[k])}, "
                                                 "which no VERTEX_SE2 line defines")


def _chain_odometry(ei: IntArray, ej: IntArray, meas: FloatArray, lines: list[int],
                    file: str) -> dict[int, tuple[float, float, float]]:
    """Initial poses of an edges-only file: origin at the smallest id, then each vertex
    ``v`` is ``pose[v-1] * measurement(v-1 -> v)`` (first such edge in the file)."""
    used = np.union1d(ei, ej)
    odo = np.flatnonzero(ej == ei + 1)
    first: dict[int, int] = {}
    for k in odo[::-1]:          # reversed so the first edge in the file wins
        first[int(ej[k])] = int(k)
    out: dict[int, tuple[float, float, float]] = {}
    pose = np.zeros(3)
    start = int(used[0])
    for v in range(start, int(used[-1]) + 1):
        if v != start:
            k_edge = first.get(v)
            if k_edge is None:
                if v not in used:
                    continue
                uses = np.flatnonzero((ei == v) | (ej == v))
                raise G2oFormatError(
                    file, lines[int(uses[0])],
                    f"vertex {v} has no VERTEX_SE2 line and no odometry edge {v - 1} -> {v} "
                    "to initialise it from (edges-only files are chained i -> i+1)")
            pose = se2_compose(np.array(out[int(ei[k_edge])]), meas[k_edge])
        out[v] = (float(pose[0]), float(pose[1]), float(pose[2]))
    return out


def write_g2o(graph: G2oGraph, path: str | Path) -> None:
    """Write ``graph`` as VERTEX_SE2 / EDGE_SE2 / FIX lines with repr-precision floats,
    so :func:`read_g2o` gives back the same numbers bit for bit."""
    info = np.asarray(graph.information, dtype=np.float64)
    if info.shape[0] and not np.array_equal(info, np.swapaxes(info, 1, 2)):
        k = int(np.argmax(np.any(info != np.swapaxes(info, 1, 2), axis=(1, 2))))
        raise G2oError(f"cannot write {path}: information matrix of edge {k} "
                       f"({int(graph.edge_i[k])} -> {int(graph.edge_j[k])}) is not symmetric")
    rows: list[str] = []
    for vid, pose in zip(graph.ids.tolist(), graph.poses.tolist(), strict=True):
        rows.append(f"VERTEX_SE2 {vid} {pose[0]!r} {pose[1]!r} {pose[2]!r}")
    for vid in graph.fixed.tolist():
        rows.append(f"FIX {vid}")
    up = info[:, _UPPER[0], _UPPER[1]].tolist()
    for i, j, m, u in zip(graph.edge_i.tolist(), graph.edge_j.tolist(),
                          graph.measurements.tolist(), up, strict=True):
        rows.append(f"EDGE_SE2 {i} {j} " + " ".join(repr(float(x)) for x in (*m, *u)))
    Path(path).write_text("\n".join(rows) + "\n", encoding="utf-8")

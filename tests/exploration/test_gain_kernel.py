"""The information-gain ray kernel on precomputed beam steps (on a grid framed by
ray-stopping cells) counts exactly what the per-step ray casting counted (the reference
below is the kernel it replaced)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pytest
from numpy.typing import NDArray

from navstack.exploration.gain import (
    _beam_table,
    _codes,
    _union,
    visible_unknown,
    visible_unknown_along,
)
from navstack.exploration.grid_view import GridView


@nb.njit(cache=True)
def _reference(unknown: NDArray[np.bool_], blocked: NDArray[np.bool_],
               rows: NDArray[np.int64], cols: NDArray[np.int64], offsets: NDArray[np.int64],
               range_cells: float, beams: int, stamp: NDArray[np.int32]) -> NDArray[np.int64]:
    """The previous kernel: every half-cell step of every beam, floor per step."""
    h, w = unknown.shape
    groups = offsets.size - 1
    out = np.zeros(groups, dtype=np.int64)
    steps = math.ceil(range_cells * 2.0)
    for g in range(groups):
        tag = g + 1
        count = 0
        for k in range(offsets[g], offsets[g + 1]):
            r0 = rows[k] + 0.5
            c0 = cols[k] + 0.5
            for b in range(beams):
                a = 2.0 * math.pi * b / beams
                dr = math.sin(a) * 0.5
                dc = math.cos(a) * 0.5
                for s in range(1, steps + 1):
                    r = math.floor(r0 + dr * s)
                    c = math.floor(c0 + dc * s)
                    if r < 0 or r >= h or c < 0 or c >= w:
                        break
                    if blocked[r, c]:
                        break
                    if unknown[r, c] and stamp[r, c] != tag:
                        stamp[r, c] = tag
                        count += 1
        out[g] = count
    return out


def _compare(unknown: NDArray[np.bool_], blocked: NDArray[np.bool_], rows: NDArray[np.int64],
             cols: NDArray[np.int64], offsets: NDArray[np.int64], range_cells: float,
             beams: int) -> None:
    s_ref = np.zeros(unknown.shape, np.int32)
    want = _reference(unknown, blocked, rows, cols, offsets, range_cells, beams, s_ref)
    got, s_new = _union(_codes(unknown, blocked), rows, cols, offsets, range_cells, beams)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(s_new, s_ref)  # the same cells, tagged by the same group


@pytest.mark.parametrize("seed", range(4))
def test_union_matches_the_per_step_kernel_on_random_grids(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(40):
        h, w = (int(v) for v in rng.integers(3, 90, 2))
        unknown = rng.random((h, w)) < rng.random()
        blocked = rng.random((h, w)) < 0.15 * rng.random()
        n = int(rng.integers(1, 12))
        rows = rng.integers(0, h, n).astype(np.int64)
        cols = rng.integers(0, w, n).astype(np.int64)
        cuts = np.sort(rng.integers(0, n + 1, int(rng.integers(0, 4))))
        offsets = np.concatenate(([0], cuts, [n])).astype(np.int64)
        range_cells = float(rng.choice([70.0, 35.0, 10.0, 0.4 + 60.0 * rng.random()]))
        beams = int(rng.choice([180, 720, 90, 7, int(rng.integers(1, 400))]))
        _compare(unknown, blocked, rows, cols, offsets, range_cells, beams)


def test_union_matches_on_a_wide_grid_far_from_the_origin() -> None:
    """Viewpoints at rows/columns in the thousands: where ``R + 0.5 + dr s`` rounds
    differently from ``0.5 + dr s`` the flagged steps are computed per viewpoint."""
    rng = np.random.default_rng(7)
    h, w = 2100, 2300
    unknown = rng.random((h, w)) < 0.6
    blocked = rng.random((h, w)) < 0.002
    rows = np.array([0, 5, 1037, 2047, 2099, 1500], np.int64)
    cols = np.array([2299, 3, 2048, 1023, 11, 2222], np.int64)
    _compare(unknown, blocked, rows, cols, np.arange(rows.size + 1, dtype=np.int64), 70.0, 180)
    _compare(unknown, blocked, rows, cols, np.array([0, 2, 6], np.int64), 70.0, 360)


def test_beam_table_drops_only_repeated_cells_and_flags_near_integer_steps() -> None:
    dr, dc, tr, tc, ts, amb, count = _beam_table(70.0, 180)
    steps = math.ceil(140.0)
    assert count.max() <= steps and count.min() >= 70  # at least one step per cell crossed
    for b in (0, 15, 45, 77):
        n = int(count[b])
        assert list(ts[b, :n]) == sorted(ts[b, :n]) and ts[b, 0] == 1
        for j in range(n):
            s = int(ts[b, j])
            yr, yc = 0.5 + dr[b] * s, 0.5 + dc[b] * s
            assert (tr[b, j], tc[b, j]) == (math.floor(yr), math.floor(yc))
            near = [abs(y - round(y)) < 1e-6 and 2 * x != math.floor(2 * x)
                    for x, y in ((dr[b] * s, yr), (dc[b] * s, yc))]
            assert bool(amb[b, j]) == any(near)
    # beam 0 (along +columns) enters a new cell every second half-cell step; 0.5 s is
    # exact, so nothing is flagged and half of the steps are dropped
    assert not dr[0] and dc[0] == 0.5
    assert count[0] == steps // 2 and not amb[0].any()
    assert amb[15, :count[15]].any()  # 30 degrees: sin(a) / 2 s lands next to integers


def _reference_along(view: GridView, paths: list[NDArray[np.int64]], sensor_range: float,
                     beams: int, seen_from: tuple[int, int] | None) -> NDArray[np.int64]:
    """The previous ``visible_unknown_along``: every path cell, the robot's included."""
    offsets = np.zeros(len(paths) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([len(q) for q in paths])
    cells = np.concatenate(paths).astype(np.int64)
    stop = ~view.unknown & ~view.free
    unknown = view.unknown.copy()
    range_cells = sensor_range / view.resolution
    if seen_from is not None:
        here = np.zeros(view.shape, dtype=np.int32)
        _reference(unknown, stop, np.array([seen_from[0]]), np.array([seen_from[1]]),
                   np.array([0, 1]), range_cells, beams, here)
        unknown &= here == 0
    return _reference(unknown, stop, cells[:, 0].copy(), cells[:, 1].copy(), offsets,
                      range_cells, beams, np.zeros(view.shape, dtype=np.int32))


def test_visible_unknown_and_along_match_the_previous_functions() -> None:
    """Paths ending at the robot's cell (which is left out: from there nothing is left
    to count once its view is removed), paths not ending there, no ``seen_from``."""
    rng = np.random.default_rng(3)
    for _ in range(60):
        h, w = (int(v) for v in rng.integers(5, 80, 2))
        unknown = rng.random((h, w)) < rng.random()
        blocked = rng.random((h, w)) < 0.1 * rng.random()
        free = ~unknown & ~blocked
        view = GridView(unknown, free, free.copy(), 0.05)
        paths = [np.column_stack((rng.integers(0, h, n), rng.integers(0, w, n))).astype(
            np.int64) for n in rng.integers(1, 8, int(rng.integers(1, 5)))]
        robot = (int(rng.integers(0, h)), int(rng.integers(0, w)))
        if rng.random() < 0.7:
            for p in paths:
                p[-1] = robot
        sensor_range = float(rng.choice([3.5, 1.0, 0.05 + 4.0 * rng.random()]))
        beams = int(rng.choice([180, 90, int(rng.integers(1, 400))]))
        for seen in (robot, None):
            np.testing.assert_array_equal(
                visible_unknown_along(view, paths, sensor_range, beams, seen_from=seen),
                _reference_along(view, paths, sensor_range, beams, seen))
        r, c = paths[0][:, 0], paths[0][:, 1]
        want = [_reference(unknown, ~unknown & ~free, r, c, np.array([k, k + 1]),
                           sensor_range / 0.05,
                           beams, np.zeros((h, w), np.int32))[0] for k in range(r.size)]
        assert list(visible_unknown(view, r, c, sensor_range, beams)) == want


def test_union_matches_for_viewpoints_off_the_grid() -> None:
    """A viewpoint outside the grid: its beams count from where they enter it, as before
    (the frame grows by the distance outside)."""
    rng = np.random.default_rng(11)
    h, w = 40, 50
    unknown = rng.random((h, w)) < 0.7
    blocked = rng.random((h, w)) < 0.02
    rows = np.array([-1, -30, 45, 20, 200, 39], np.int64)
    cols = np.array([10, -2, 49, 50, 25, -1], np.int64)
    for range_cells in (70.0, 12.0, 3.0):
        _compare(unknown, blocked, rows, cols, np.arange(rows.size + 1, dtype=np.int64),
                 range_cells, 180)

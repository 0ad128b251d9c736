"""Log-odds occupancy grid mapping from laser scans (the map half of slam_toolbox/gmapping).

Model (Thrun, Burgard, Fox, *Probabilistic Robotics*, 2005, ch. 9.2, Table 9.1): every
cell stores the log-odds ``l = log(p / (1 - p))`` of being occupied, prior ``l0 = 0``
(p = 0.5).  Each scan adds the inverse sensor model: ``l_occ`` to the cell a beam ends in
(a return), ``l_free`` to every cell the beam crosses before it.  The defaults
``l_occ = logit(0.7)`` and ``l_free = logit(0.4)`` are OctoMap's hit/miss probabilities
(Hornung et al. 2013, Autonomous Robots 34(3)); values are clamped to ``[l_min, l_max] =
[-5, 5]`` (p in [0.0067, 0.9933]) so a cell can still change its mind after thousands of
agreeing observations (OctoMap's clamping policy, with wider bounds).

Per scan a cell is updated at most once, and a hit takes precedence over a miss in the
same scan (Table 9.1 loops over the cells in the perceptual field, each updated once per
measurement; OctoMap's ``insertPointCloud`` does the same).  This keeps the cells next to
the sensor from being crossed 360 times per scan and stops grazing beams from erasing the
wall cell another beam of the same scan just hit.

Beams are traced with the exact grid traversal of Amanatides & Woo ("A Fast Voxel
Traversal Algorithm for Ray Tracing", Eurographics 1987): every cell the segment passes
through is visited, so a beam ending just behind a wall surface clears no wall cell.

Range semantics (:func:`scan_endpoints`) follow gmapping's ``maxRange``/``maxUrange`` and
slam_toolbox's ``max_laser_range``: returns beyond ``max_usable_range`` are cut there and
only clear space; readings at or beyond ``range_max`` (and ``+inf``, REP-117 "no return")
clear space up to ``min(range_max, max_usable_range)`` when ``clear_no_returns`` is set
(gmapping's recommended ``maxUrange < sensor range <= maxRange`` set-up) and are dropped
otherwise (Karto's choice); readings below ``range_min``, ``-inf`` and NaN are dropped.

Grid convention (as :class:`~navstack.core.msgs.OccupancyGrid`): ``data[row, col]``, row 0
at the lowest y, ``origin`` the world coordinates of the outer corner of cell (0, 0).  The
cell lattice is fixed at construction (``bounds`` corner, or world (0, 0)) and the grid
grows by whole cells, so growth never moves a cell in the world.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Literal, NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from navstack.core.errors import InvalidMessage, NavstackError
from navstack.core.geometry import se2_compose
from navstack.core.map_files import DEFAULT_FREE_THRESH, DEFAULT_OCCUPIED_THRESH, save_map
from navstack.core.msgs import Header, LaserScan, MapMetaData, OccupancyGrid, Point, Pose
from navstack.core.params import Params

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
GridMode = Literal["trinary", "probability"]
UNKNOWN_PIXEL = 205  # map_saver's grey for unknown space


def logit(p: float) -> float:
    """Log-odds ``log(p / (1 - p))`` of a probability in (0, 1)."""
    return math.log(p / (1.0 - p))


L_OCC_DEFAULT = logit(0.7)
L_FREE_DEFAULT = logit(0.4)


def free_thresh_after(scans: int, l_free: float = L_FREE_DEFAULT) -> float:
    """The trinary ``free_thresh`` at which a cell shows free once ``scans`` scans more
    crossed it (each adding ``l_free``) than ended in it -- precisely, once its log-odds
    is at most ``scans * l_free`` (a cell some scan ended in needs more).

    The threshold sits halfway between ``scans`` and ``scans - 1`` free updates, so the
    float32 sums of the grid fall clearly on one side.  With OctoMap's ``l_free =
    logit(0.4)`` map_server's ``free_thresh`` 0.196 is 3.5 updates: four scans.  Karto
    (slam_toolbox's map) shows a cell free once more than ``MinPassThrough`` = 2 rays
    crossed it and at most ``OccupancyThreshold`` = 10 % of them ended in it
    (``OccupancyGrid::UpdateCell``), so its free space appears after one or two scans
    (docs/mapping.md, "Free space of the published map")."""
    if scans < 1:
        raise MappingError(f"scans must be at least 1, got {scans}")
    if not l_free < 0.0:
        raise MappingError(f"l_free must be negative, got {l_free}")
    return 1.0 / (1.0 + math.exp(-(scans - 0.5) * l_free))


HIT_DEPTH = 1e-3  # [m] see scan_endpoints


class MappingError(NavstackError, ValueError):
    """The occupancy mapper was given something it cannot use."""


class MapGrowthError(MappingError):
    """Growing the grid to hold a scan would exceed ``max_cells``."""


class LogOddsParams(Params):
    """Parameters of :class:`LogOddsGrid` (``resolution`` as in slam_toolbox)."""

    resolution: float = Field(0.05, gt=0.0)
    """Cell size [m] (slam_toolbox ``resolution``)."""
    l_occ: float = Field(L_OCC_DEFAULT, gt=0.0)
    """Log-odds added to a cell a beam ends in (logit(0.7), OctoMap ``prob_hit``)."""
    l_free: float = Field(L_FREE_DEFAULT, lt=0.0)
    """Log-odds added to a cell a beam crosses (logit(0.4), OctoMap ``prob_miss``)."""
    l_min: float = Field(-5.0, lt=0.0)
    """Lower clamp of a cell's log-odds."""
    l_max: float = Field(5.0, gt=0.0)
    """Upper clamp of a cell's log-odds."""
    growable: bool = True
    """Grow the grid to hold every scan; when false, beams stop at the grid border."""
    grow_margin: float = Field(2.0, ge=0.0)
    """Extra space [m] added beyond a scan when the grid grows."""
    max_cells: int = Field(40_000_000, ge=1)
    """Largest grid (cells) growth may create, e.g. 6300 x 6300 = 315 m square at 0.05."""


class ScanData(NamedTuple):
    """One planar scan: ``ranges`` [m] along ``angles`` [rad, relative to the sensor]."""

    ranges: ArrayLike
    angles: ArrayLike
    range_min: float
    range_max: float


def scan_endpoints(pose: ArrayLike, ranges: ArrayLike, angles: ArrayLike, range_min: float,
                   range_max: float, max_usable_range: float = math.inf, *,
                   clear_no_returns: bool = True) -> tuple[FloatArray, BoolArray]:
    """World end points ``(M, 2)`` and hit mask ``(M,)`` of one scan (module docstring).

    ``pose`` is the sensor pose (x, y, theta) in the map frame; ``angles`` are relative to
    its heading.  Dropped beams are left out, so ``M <= len(ranges)``.
    """
    p = np.asarray(pose, dtype=np.float64).reshape(3)
    r = np.asarray(ranges, dtype=np.float64).reshape(-1)
    a = np.asarray(angles, dtype=np.float64).reshape(-1)
    if r.shape != a.shape:
        raise MappingError(f"scan has {r.size} ranges but {a.size} angles; pass one angle "
                           "per beam")
    if not (np.isfinite(p).all() and np.isfinite(a).all()):
        raise InvalidMessage(f"scan pose {p.tolist()} or beam angles are not finite")
    usable = min(float(max_usable_range), float(range_max))
    ret = (r >= range_min) & (r < range_max)  # NaN and -inf fail both tests
    hit = ret & (r <= max_usable_range)
    # a return lies on the obstacle's surface; 1 mm further along the beam is inside it,
    # so a surface exactly on a cell border (simulated worlds are rasters) marks the
    # obstacle's cell, not the free cell in front of it
    length = np.where(hit, r + HIT_DEPTH, usable)
    keep = ret | (r >= range_max) if clear_no_returns and math.isfinite(usable) else ret
    length, hit, a = length[keep], hit[keep], a[keep]
    theta = a + p[2]
    ends = np.empty((length.size, 2))
    ends[:, 0] = p[0] + length * np.cos(theta)
    ends[:, 1] = p[1] + length * np.sin(theta)
    return ends, hit


@numba.njit(cache=True, inline="always")
def _clip(t0: float, t1: float, o: float, d: float, hi: float) -> tuple[float, float]:
    """Liang-Barsky: narrow [t0, t1] so o + t d stays in [0, hi]; empty if t0 > t1."""
    if d == 0.0:
        return (t0, t1) if 0.0 <= o <= hi else (1.0, 0.0)
    ta = -o / d
    tb = (hi - o) / d
    if ta > tb:
        ta, tb = tb, ta
    return max(t0, ta), min(t1, tb)


@numba.njit(cache=True)
def _integrate(logodds: NDArray[np.float32], mark: NDArray[np.int32], stamp0: int,
               ax: float, ay: float, off_col: int, off_row: int, res: float,
               sensors: FloatArray, starts: NDArray[np.int64], ends: FloatArray,
               hits: BoolArray, l_occ: float, l_free: float, l_min: float,
               l_max: float) -> None:
    """Integrate scans ``k`` = rays ``starts[k]:starts[k+1]`` seen from ``sensors[k]``.

    World point (x, y) is at cell units ``((x - ax) / res - off_col, ...)``.  Scan ``k``
    stamps cells ``stamp0 + 2k + 1`` (hit) or ``+ 2`` (free) in ``mark`` so each cell is
    updated once per scan, hits first.
    """
    h, w = logodds.shape
    for k in range(sensors.shape[0]):
        occ_stamp = stamp0 + 2 * k + 1
        free_stamp = occ_stamp + 1
        for i in range(starts[k], starts[k + 1]):
            if hits[i]:
                c = math.floor((ends[i, 0] - ax) / res - off_col)  # as the traversal's end
                r = math.floor((ends[i, 1] - ay) / res - off_row)
                if 0 <= r < h and 0 <= c < w and mark[r, c] != occ_stamp:
                    mark[r, c] = occ_stamp
                    v = logodds[r, c] + l_occ
                    logodds[r, c] = v if v < l_max else l_max
        x0 = (sensors[k, 0] - ax) / res - off_col
        y0 = (sensors[k, 1] - ay) / res - off_row
        for i in range(starts[k], starts[k + 1]):
            x1 = (ends[i, 0] - ax) / res - off_col
            y1 = (ends[i, 1] - ay) / res - off_row
            # Amanatides-Woo on the segment clipped to the grid: a ray far outside costs
            # nothing and traversal stops at the border.  Clamping the (monotone) start
            # and end cells into the grid keeps every visited cell in bounds, since each
            # step moves one cell towards the end cell.
            dx, dy = x1 - x0, y1 - y0
            t0, t1 = _clip(0.0, 1.0, x0, dx, w)
            t0, t1 = _clip(t0, t1, y0, dy, h)
            if t0 > t1:
                continue
            sx, sy = x0 + t0 * dx, y0 + t0 * dy
            cx = min(max(math.floor(sx), 0), w - 1)
            cy = min(max(math.floor(sy), 0), h - 1)
            tx = min(max(math.floor(x0 + t1 * dx), 0), w - 1)
            ty = min(max(math.floor(y0 + t1 * dy), 0), h - 1)
            step_x, t_max_x, t_dx = 0, math.inf, math.inf
            if dx > 0.0:
                step_x, t_max_x, t_dx = 1, (cx + 1.0 - sx) / dx, 1.0 / dx
            elif dx < 0.0:
                step_x, t_max_x, t_dx = -1, (sx - cx) / -dx, -1.0 / dx
            step_y, t_max_y, t_dy = 0, math.inf, math.inf
            if dy > 0.0:
                step_y, t_max_y, t_dy = 1, (cy + 1.0 - sy) / dy, 1.0 / dy
            elif dy < 0.0:
                step_y, t_max_y, t_dy = -1, (sy - cy) / -dy, -1.0 / dy
            # the end cell is visited last unless it holds this beam's hit
            n = abs(tx - cx) + abs(ty - cy) + (0 if hits[i] and t1 == 1.0 else 1)
            for _ in range(n):
                if mark[cy, cx] < occ_stamp:
                    mark[cy, cx] = free_stamp
                    v = logodds[cy, cx] + l_free  # (builtin max() is 1.7x slower here)
                    logodds[cy, cx] = v if v > l_min else l_min
                # reach the end cell exactly even when rounding disagrees with the t's
                if cx == tx or (cy != ty and t_max_y <= t_max_x):
                    cy += step_y
                    t_max_y += t_dy
                else:
                    cx += step_x
                    t_max_x += t_dx


def _stop_short(origin: FloatArray, ends: FloatArray, margin: float) -> FloatArray:
    """``ends`` (M, 2, the returns of one scan in beam order) moved back towards ``origin``
    until they are ``margin`` from the surface they lie on, measured across it.  The
    surface's direction at a return is the chord between its neighbours two beams away;
    a beam meeting it at angle ``b`` stops ``margin / sin(b)`` short (at most ten times
    ``margin``: a grazing beam, or one at a depth edge, clears little near its end)."""
    d = ends - origin
    length = np.hypot(d[:, 0], d[:, 1])
    unit = d / np.maximum(length, 1e-9)[:, None]
    n = ends.shape[0]
    idx = np.arange(n)
    chord = ends[np.minimum(idx + 2, n - 1)] - ends[np.maximum(idx - 2, 0)]
    span = np.hypot(chord[:, 0], chord[:, 1])
    sin_b = np.abs(unit[:, 0] * chord[:, 1] - unit[:, 1] * chord[:, 0]) / np.maximum(span, 1e-9)
    sin_b = np.where(span > 1e-9, sin_b, 1.0)  # a single return: head-on
    short = margin / np.maximum(sin_b, 0.1)
    keep = np.maximum(length - short, 0.0) / np.maximum(length, 1e-9)
    return origin + d * keep[:, None]


class LogOddsGrid:
    """Growable log-odds occupancy grid (see the module docstring for model and sources).

    ``bounds = (x_min, y_min, x_max, y_max)`` [m] preallocates the grid with its origin at
    ``(x_min, y_min)``; without it the grid starts empty on the lattice of world (0, 0)
    and grows with the first scan.  Growth adds ``grow_margin`` metres beyond the scan and
    at least half the current size on a growing side (amortised O(1) per cell).
    """

    def __init__(self, resolution: float = 0.05,
                 bounds: tuple[float, float, float, float] | None = None, *,
                 l_occ: float = L_OCC_DEFAULT, l_free: float = L_FREE_DEFAULT,
                 l_min: float = -5.0, l_max: float = 5.0, growable: bool = True,
                 grow_margin: float = 2.0, max_cells: int = 40_000_000) -> None:
        self.params = LogOddsParams.from_mapping(dict(
            resolution=resolution, l_occ=l_occ, l_free=l_free, l_min=l_min, l_max=l_max,
            growable=growable, grow_margin=grow_margin, max_cells=max_cells))
        res = self.params.resolution
        self._res = res
        self._off_col = 0
        self._off_row = 0
        self._scans = 0
        if bounds is None:
            self._ax, self._ay = 0.0, 0.0
            shape = (0, 0)
        else:
            x0, y0, x1, y1 = (float(v) for v in bounds)
            if not (math.isfinite(x0 + y0 + x1 + y1) and x1 > x0 and y1 > y0):
                raise MappingError(f"bounds {bounds} must be finite (x_min, y_min, x_max, y_max)"
                                   " with x_max > x_min and y_max > y_min")
            self._ax, self._ay = x0, y0
            shape = (math.ceil((y1 - y0) / res - 1e-9), math.ceil((x1 - x0) / res - 1e-9))
            self._check_size(shape[0] * shape[1])
        self._l = np.zeros(shape, dtype=np.float32)
        self._mark = np.zeros(shape, dtype=np.int32)

    @classmethod
    def from_params(cls, params: LogOddsParams,
                    bounds: tuple[float, float, float, float] | None = None) -> LogOddsGrid:
        return cls(bounds=bounds, **params.model_dump())

    def copy(self) -> LogOddsGrid:
        """An independent copy (same lattice, values, observed marks and scan count)."""
        out = LogOddsGrid.__new__(LogOddsGrid)
        out.__dict__.update(self.__dict__)
        out._l = self._l.copy()
        out._mark = self._mark.copy()
        return out

    # --- geometry ------------------------------------------------------------------------
    @property
    def resolution(self) -> float:
        return self._res

    @property
    def origin(self) -> tuple[float, float]:
        """World (x, y) of the outer corner of cell (0, 0)."""
        return (self._ax + self._off_col * self._res, self._ay + self._off_row * self._res)

    @property
    def shape(self) -> tuple[int, int]:
        """``(height, width)`` in cells."""
        return (int(self._l.shape[0]), int(self._l.shape[1]))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` [m] of the grid."""
        ox, oy = self.origin
        h, w = self.shape
        return (ox, oy, ox + w * self._res, oy + h * self._res)

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """``(row, col)`` of the cell holding world point (x, y); may lie outside the grid."""
        return (math.floor((y - self._ay) / self._res - self._off_row),
                math.floor((x - self._ax) / self._res - self._off_col))

    def cell_center(self, row: int, col: int) -> tuple[float, float]:
        ox, oy = self.origin
        return (ox + (col + 0.5) * self._res, oy + (row + 0.5) * self._res)

    # --- state ---------------------------------------------------------------------------
    @property
    def log_odds(self) -> NDArray[np.float32]:
        """Read-only ``float32[H, W]`` log-odds (0 for never-observed cells)."""
        view = self._l.view()
        view.flags.writeable = False
        return view

    @property
    def observed(self) -> BoolArray:
        """``bool[H, W]``: cells some beam has crossed or ended in."""
        return self._mark > 0

    @property
    def scan_count(self) -> int:
        return self._scans

    def probability(self) -> FloatArray:
        """``float64[H, W]`` occupancy probability ``1 / (1 + exp(-l))`` (0.5 unobserved)."""
        return 1.0 / (1.0 + np.exp(-self._l.astype(np.float64)))

    # --- integration ---------------------------------------------------------------------
    def integrate_scan(self, origin_xy: ArrayLike, endpoints_xy: ArrayLike,
                       hit_mask: ArrayLike) -> None:
        """Add one scan: beams from ``origin_xy`` (2,) to ``endpoints_xy`` (N, 2) [m, map
        frame]; ``hit_mask`` (N,) is true where the beam ended on an obstacle."""
        origin = np.asarray(origin_xy, dtype=np.float64).reshape(1, 2)
        ends = np.ascontiguousarray(endpoints_xy, dtype=np.float64)
        hits = np.ascontiguousarray(hit_mask, dtype=np.bool_)
        if ends.ndim != 2 or ends.shape[1] != 2 or hits.shape != (ends.shape[0],):
            raise MappingError(f"endpoints must have shape (N, 2) and hit_mask (N,); got "
                               f"{ends.shape} and {hits.shape}")
        self._integrate(origin, np.array([0, ends.shape[0]], dtype=np.int64), ends, hits)

    def integrate_scans(self, poses: ArrayLike, scans: Sequence[LaserScan | ScanData],
                        max_usable_range: float = math.inf, *,
                        sensor_pose: ArrayLike | None = None,
                        clear_no_returns: bool = True, clear_only: bool = False) -> None:
        """Add a whole set of scans in one pass (rebuilding a map from a pose graph).

        ``poses`` (K, 3) are the scans' poses in the map frame: sensor poses, or robot
        poses when ``sensor_pose`` (the sensor's (x, y, yaw) in the robot frame) is given.
        Each scan is a :class:`LaserScan` or a :class:`ScanData`; ranges are interpreted
        by :func:`scan_endpoints` with ``max_usable_range``.  ``clear_only``: the scans
        only add free space and mark nothing -- each return's beam stops 1.5 cells short
        of the surface it hit, measured across that surface (:func:`_stop_short`), and
        the cells within one cell of any of their returns keep their value.  What a
        passing person left behind is erased; a wall is not: a beam that grazes a wall
        runs along the cells of its face, and stopping 1.5 cells short along the beam
        alone let such beams erode a wall whose face lies on a cell boundary to
        "unknown" (exploration then saw frontiers along it).
        """
        pose_arr = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        if pose_arr.shape[0] != len(scans):
            raise MappingError(f"{pose_arr.shape[0]} poses for {len(scans)} scans; pass one "
                               "pose per scan")
        if not scans:
            return
        if sensor_pose is not None:
            pose_arr = se2_compose(pose_arr, np.asarray(sensor_pose, dtype=np.float64))
        all_ends: list[FloatArray] = []
        all_hits: list[BoolArray] = []
        returns: list[FloatArray] = []
        starts = np.zeros(len(scans) + 1, dtype=np.int64)
        for k, scan in enumerate(scans):
            if isinstance(scan, LaserScan):
                rng = np.asarray(scan.ranges, dtype=np.float64)
                ang = scan.angle_min + scan.angle_increment * np.arange(rng.size)
                data = ScanData(rng, ang, scan.range_min, scan.range_max)
            else:
                data = scan
            ends, hits = scan_endpoints(pose_arr[k], data.ranges, data.angles, data.range_min,
                                        data.range_max, max_usable_range,
                                        clear_no_returns=clear_no_returns)
            if clear_only and hits.any():
                returns.append(ends[hits])
                ends = ends.copy()
                ends[hits] = _stop_short(pose_arr[k, :2], ends[hits], 1.5 * self._res)
                hits = np.zeros_like(hits)
            all_ends.append(ends)
            all_hits.append(hits)
            starts[k + 1] = starts[k] + hits.size
        sensors = np.ascontiguousarray(pose_arr[:, :2])
        ends_all = np.concatenate(all_ends)
        kept = self._protect(np.concatenate(returns), sensors, ends_all) if returns else None
        self._integrate(sensors, starts, ends_all, np.concatenate(all_hits))
        if kept is not None:
            rows, cols, values = kept
            self._l[rows, cols] = values

    def _protect(self, points: FloatArray, sensors: FloatArray, ends: FloatArray
                 ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float32]]:
        """Cells within one cell of ``points`` and their current log-odds (the grid first
        grown to hold ``sensors`` and ``ends``, as the integration would)."""
        if self.params.growable:
            lo = np.minimum(sensors.min(axis=0), ends.min(axis=0, initial=np.inf))
            hi = np.maximum(sensors.max(axis=0), ends.max(axis=0, initial=-np.inf))
            self._ensure_contains(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
        r = np.floor((points[:, 1] - self._ay) / self._res - self._off_row).astype(np.intp)
        c = np.floor((points[:, 0] - self._ax) / self._res - self._off_col).astype(np.intp)
        h, w = self.shape
        rows = (r[:, None] + np.array([-1, -1, -1, 0, 0, 0, 1, 1, 1])).ravel()
        cols = (c[:, None] + np.array([-1, 0, 1, -1, 0, 1, -1, 0, 1])).ravel()
        ok = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        flat = np.unique(rows[ok] * w + cols[ok])
        rows, cols = flat // w, flat % w
        return rows, cols, self._l[rows, cols].copy()

    def _integrate(self, sensors: FloatArray, starts: NDArray[np.int64], ends: FloatArray,
                   hits: BoolArray) -> None:
        if not (np.isfinite(sensors).all() and np.isfinite(ends).all()):
            raise InvalidMessage("scan origin or end points contain NaN or inf; drop invalid "
                                 "beams first (scan_endpoints does)")
        if self.params.growable:
            lo = np.minimum(sensors.min(axis=0), ends.min(axis=0, initial=np.inf))
            hi = np.maximum(sensors.max(axis=0), ends.max(axis=0, initial=-np.inf))
            self._ensure_contains(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
        n_scans = sensors.shape[0]
        if 2 * (self._scans + n_scans) + 2 >= np.iinfo(np.int32).max:
            self._mark[self._mark > 0] = 1  # renumber stamps; keeps "observed"
            self._scans = 1
        p = self.params
        _integrate(self._l, self._mark, 2 * self._scans, self._ax, self._ay, self._off_col,
                   self._off_row, self._res, sensors, starts, ends, hits, p.l_occ, p.l_free,
                   p.l_min, p.l_max)
        self._scans += n_scans

    def _check_size(self, cells: int) -> None:
        if cells > self.params.max_cells:
            raise MapGrowthError(
                f"the map would need {cells} cells (> max_cells {self.params.max_cells}); a "
                "scan end point or pose is far away (bad range or pose?) -- clip ranges with "
                "max_usable_range, or raise max_cells / resolution")

    def _ensure_contains(self, x0: float, y0: float, x1: float, y1: float) -> None:
        """Grow (by whole cells, values kept) until [x0, x1] x [y0, y1] lies inside."""
        (r0, c0), (r1, c1) = self.world_to_cell(x0, y0), self.world_to_cell(x1, y1)
        h, w = self.shape
        if h and w and r0 >= 0 and c0 >= 0 and r1 < h and c1 < w:
            return
        m = max(1, math.ceil(self.params.grow_margin / self._res))
        if h == 0 or w == 0:
            left, bottom, new_w, new_h = -(c0 - m), -(r0 - m), c1 - c0 + 1 + 2 * m, \
                r1 - r0 + 1 + 2 * m
        else:
            left = max(m - c0, w // 2) if c0 < 0 else 0
            right = max(c1 - w + 1 + m, w // 2) if c1 >= w else 0
            bottom = max(m - r0, h // 2) if r0 < 0 else 0
            top = max(r1 - h + 1 + m, h // 2) if r1 >= h else 0
            new_w, new_h = w + left + right, h + bottom + top
        self._check_size(new_w * new_h)
        grown_l = np.zeros((new_h, new_w), dtype=np.float32)
        grown_m = np.zeros((new_h, new_w), dtype=np.int32)
        grown_l[bottom:bottom + h, left:left + w] = self._l
        grown_m[bottom:bottom + h, left:left + w] = self._mark
        self._l, self._mark = grown_l, grown_m
        self._off_col -= left
        self._off_row -= bottom

    # --- output --------------------------------------------------------------------------
    def _crop_slices(self, crop: bool) -> tuple[slice, slice]:
        if not crop:
            return slice(None), slice(None)
        obs = self._mark > 0
        rows, cols = np.flatnonzero(obs.any(axis=1)), np.flatnonzero(obs.any(axis=0))
        if rows.size == 0:
            raise MappingError("nothing has been observed yet, so there is no map to crop; "
                               "integrate a scan first or pass crop=False")
        return slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)

    def to_occupancy_grid(self, frame_id: str = "map", stamp: float = 0.0,
                          occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
                          free_thresh: float = DEFAULT_FREE_THRESH, *, crop: bool = False,
                          mode: GridMode = "trinary") -> OccupancyGrid:
        """The map as a ``nav_msgs/OccupancyGrid``.

        ``trinary`` (what slam_toolbox and gmapping publish): ``p > occupied_thresh`` ->
        100, ``p < free_thresh`` -> 0, anything else and never-observed cells -> -1
        (map_server's thresholds and strictness).  ``probability``: ``rint(100 p)`` for
        observed cells, -1 otherwise.  ``crop`` trims to the observed bounding box.
        """
        if not 0.0 <= free_thresh < occupied_thresh <= 1.0:
            raise MappingError(f"free_thresh {free_thresh} and occupied_thresh "
                               f"{occupied_thresh} must satisfy 0 <= free_thresh < "
                               "occupied_thresh <= 1; typical values are 0.196 and 0.65")
        if mode not in ("trinary", "probability"):
            raise MappingError(f"unknown grid mode {mode!r}; use 'trinary' or 'probability'")
        rs, cs = self._crop_slices(crop)
        obs = self._mark[rs, cs] > 0
        data = np.full(obs.shape, -1, dtype=np.int8)
        bounds = _trinary_bounds(occupied_thresh, free_thresh) if mode == "trinary" else None
        if bounds is not None:  # the same cells, compared in log-odds (no exp per cell)
            lv = self._l[rs, cs]
            data[obs & (lv >= bounds[0])] = 100
            data[obs & (lv <= bounds[1])] = 0
        else:
            p = 1.0 / (1.0 + np.exp(-self._l[rs, cs].astype(np.float64)))
            if mode == "trinary":
                data[obs & (p > occupied_thresh)] = 100
                data[obs & (p < free_thresh)] = 0
            else:
                data[obs] = np.rint(100.0 * p[obs]).astype(np.int8)
        ox = self._ax + (self._off_col + (cs.start or 0)) * self._res
        oy = self._ay + (self._off_row + (rs.start or 0)) * self._res
        height, width = obs.shape
        info = MapMetaData(map_load_time=stamp, resolution=self._res, width=int(width),
                           height=int(height), origin=Pose(Point(ox, oy, 0.0)))
        return OccupancyGrid(Header(stamp, frame_id), info, data)

    def save(self, yaml_path: str | Path, mode: str = "trinary",
             occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
             free_thresh: float = DEFAULT_FREE_THRESH, *, crop: bool = True) -> Path:
        """Write a map_server YAML + image (Nav2 map_saver semantics); returns the image path.

        ``trinary`` saves :meth:`to_occupancy_grid` in trinary form, classified with the
        thresholds given, and writes map_saver's defaults (0.65 / 0.196) into the YAML:
        they reload the three grey levels as exactly the same cells, whereas a written
        ``free_thresh`` above 0.196 would reload unknown grey 205 as free (slam_toolbox
        issue #587).  ``scale``/``raw`` save the ``probability`` grid with the thresholds
        given.
        """
        grid_mode: GridMode = "trinary" if mode == "trinary" else "probability"
        grid = self.to_occupancy_grid(occupied_thresh=occupied_thresh, free_thresh=free_thresh,
                                      crop=crop, mode=grid_mode)
        if grid_mode == "trinary":
            occupied_thresh, free_thresh = DEFAULT_OCCUPIED_THRESH, DEFAULT_FREE_THRESH
        return save_map(grid, yaml_path, mode=mode, occupied_thresh=occupied_thresh,
                        free_thresh=free_thresh)

    def save_png(self, path: str | Path, *, crop: bool = True) -> Path:
        """Greyscale picture for humans: white free, black occupied, shades of grey for
        the probability, map_saver's grey 205 for never-observed cells; north up."""
        from PIL import Image

        rs, cs = self._crop_slices(crop)
        p = 1.0 / (1.0 + np.exp(-self._l[rs, cs].astype(np.float64)))
        pixels = np.where(self._mark[rs, cs] > 0, np.rint(255.0 * (1.0 - p)), UNKNOWN_PIXEL)
        out = Path(path)
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(np.ascontiguousarray(pixels[::-1].astype(np.uint8))).save(out)
        except (OSError, ValueError) as exc:
            raise MappingError(f"{out}: cannot write the map picture ({exc}); check the folder "
                               "and use a .png/.pgm name") from None
        return out


_BOUNDS: dict[tuple[float, float], tuple[np.float32, np.float32] | None] = {}


def _probability(lv: NDArray[np.float32]) -> NDArray[np.float64]:
    """Occupancy probability of log-odds ``lv``, as :meth:`LogOddsGrid.to_occupancy_grid`
    computes it."""
    return 1.0 / (1.0 + np.exp(-lv.astype(np.float64)))


def _float32_threshold(pred_above: bool, thresh: float) -> np.float32 | None:
    """The smallest float32 log-odds whose :func:`_probability` is ``> thresh``
    (``pred_above``), or the largest whose probability is ``< thresh``; ``None`` unless
    the float32 values around it confirm a single crossing."""
    lo, hi = np.float32(-80.0), np.float32(80.0)
    lo_i, hi_i = int(lo.view(np.int32)), int(hi.view(np.int32))

    def key(i: int) -> int:  # float32 bit pattern -> monotone integer
        return i if i >= 0 else -(i & 0x7FFFFFFF)

    def value(k: int) -> np.float32:
        bits = k if k >= 0 else (-k) | -0x80000000
        return np.array([bits], dtype=np.int32).view(np.float32)[0]

    a, b = key(lo_i), key(hi_i)

    def test(k: int) -> bool:
        p = float(_probability(np.array([value(k)], dtype=np.float32))[0])
        return p > thresh if pred_above else not p < thresh

    if test(a) or not test(b):
        return None
    while b - a > 1:  # test(a) False, test(b) True
        m = (a + b) // 2
        if test(m):
            b = m
        else:
            a = m
    ks = np.arange(b - 2048, b + 2048)
    bits = np.where(ks >= 0, ks, (-ks) | -0x80000000).astype(np.int32)
    p = _probability(bits.view(np.float32))
    hit = p > thresh if pred_above else ~(p < thresh)
    if not (hit == (ks >= b)).all():
        return None
    return value(b) if pred_above else value(a)


def _trinary_bounds(occupied_thresh: float, free_thresh: float
                    ) -> tuple[np.float32, np.float32] | None:
    """``(L, U)``: a float32 log-odds ``l`` has probability ``> occupied_thresh`` iff
    ``l >= L`` and ``< free_thresh`` iff ``l <= U`` (the probability is monotone in
    ``l``; found once per threshold pair by bisection over float32 values and checked
    on the 4096 values around each bound).  ``None``: compare probabilities instead."""
    k = (occupied_thresh, free_thresh)
    if k not in _BOUNDS:
        lo = _float32_threshold(True, occupied_thresh)
        hi = _float32_threshold(False, free_thresh)
        _BOUNDS[k] = None if lo is None or hi is None else (lo, hi)
    return _BOUNDS[k]

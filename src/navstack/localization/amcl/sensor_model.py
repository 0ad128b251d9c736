"""Laser measurement models of Nav2's AMCL over a static occupancy map.

* ``likelihood_field`` (Thrun, Burgard & Fox, *Probabilistic Robotics*, 2005, ch. 6.4):
  each beam end point is scored by the distance ``z`` to the nearest occupied cell
  (precomputed for the whole map and clamped at ``laser_likelihood_max_dist``):
  ``pz = z_hit exp(-z^2 / (2 sigma_hit^2)) + z_rand / range_max``; end points off the map
  count as ``z = laser_likelihood_max_dist``; max-range readings are ignored.  As amcl's
  ``LikelihoodFieldModel`` the beams are combined as ``p = 1 + sum pz^3`` — a deliberately
  flattened likelihood that tolerates unmodelled obstacles better than the product.
* ``likelihood_field_prob``: the same ``pz`` combined as the product ``prod pz``
  (amcl's ``LikelihoodFieldModelProb``), with optional *beam skipping* (``do_beamskip``):
  once the filter has converged, beams whose end points lie within
  ``beam_skip_distance`` of an obstacle for at most ``beam_skip_threshold`` of the
  particles are left out for all particles (an obstacle that is not in the map, e.g. a
  person); if ``beam_skip_error_threshold`` of the beams or more would be skipped the
  filter has probably converged wrongly and every beam is used.
* ``beam`` (ch. 6.3): the expected range is ray-cast in the map from each particle's
  laser pose; ``pz = z_hit N(obs - expected; sigma_hit) + z_short lambda exp(-lambda obs)``
  (only for ``obs < expected``) ``+ z_max [obs == range_max] + z_rand / range_max
  [obs < range_max]``, combined as ``1 + sum pz^3`` like amcl's ``BeamModel``.

Beams are subsampled to ``max_beams`` evenly spaced ones (amcl's integer ``step``).
Readings at or below the minimum range count as max-range readings (amcl); ``+inf`` (no
return) is a max-range reading; ``NaN`` and ``-inf`` are invalid and skipped.  All hot
loops are ``numba.njit(cache=True)`` kernels over particles x beams; each particle needs
one ``sin``/``cos`` only (beam end points are rotated, not recomputed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import InvalidMessage
from navstack.core.msgs import OccupancyGrid
from navstack.localization.amcl.params import AmclParams

FloatArray = NDArray[np.float64]

OCCUPIED_THRESHOLD = 65
"""Grid values >= this are obstacles (map_server's ``occupied_thresh`` 0.65)."""
FREE_THRESHOLD = 19
"""Grid values in ``0..FREE_THRESHOLD`` are free (map_server's ``free_thresh`` 0.196)."""


class AmclMapError(InvalidMessage):
    """An occupancy grid AMCL cannot localize in (empty, mis-shaped, rotated origin)."""


@dataclass(frozen=True, eq=False)
class AmclMap:
    """The static map as AMCL uses it.

    ``occ_state`` int8 ``(H, W)``: -1 free, 0 unknown, +1 occupied (amcl's ``map_t``);
    ``occ_dist`` float64 ``(H, W)``: distance [m] from each cell centre to the nearest
    occupied cell centre, clamped at ``max_occ_dist``; ``free_cells`` ``(M, 2)``: centres
    of the free cells (uniform sampling for global localization and recovery).
    """

    occ_state: NDArray[np.int8]
    occ_dist: FloatArray
    free_cells: FloatArray
    resolution: float
    origin_x: float
    origin_y: float
    max_occ_dist: float

    @staticmethod
    def from_occupancy_grid(grid: OccupancyGrid, max_occ_dist: float,
                            freespace_downsampling: bool = False) -> AmclMap:
        """Convert a ``nav_msgs/OccupancyGrid``; ``freespace_downsampling`` keeps every
        second free cell in each direction for the sampler (Nav2's large-map option)."""
        from scipy.ndimage import distance_transform_edt

        info = grid.info
        data = np.asarray(grid.data)
        if info.width <= 0 or info.height <= 0 or data.size != info.width * info.height:
            raise AmclMapError(f"map is {info.width} x {info.height} cells but carries "
                               f"{data.size} values; publish a non-empty grid whose data "
                               "has height * width values")
        if not info.resolution > 0.0:
            raise AmclMapError(f"map resolution must be positive, got {info.resolution}")
        origin = info.origin.to_pose2d()
        if abs(origin.theta) > 1e-9:
            raise AmclMapError(f"map origin yaw {origin.theta:.4f} rad is not supported "
                               "(nav2_amcl ignores it too); rotate the map image instead")
        cells = data.reshape(info.height, info.width).astype(np.int16)
        occupied = cells >= OCCUPIED_THRESHOLD
        free = (cells >= 0) & (cells <= FREE_THRESHOLD)
        state = np.zeros(cells.shape, np.int8)
        state[occupied] = 1
        state[free] = -1
        res = float(info.resolution)
        if occupied.any():
            dist = np.minimum(np.asarray(distance_transform_edt(~occupied, sampling=res),
                                         np.float64), max_occ_dist)
        else:
            dist = np.full(cells.shape, float(max_occ_dist))
        mask = free
        if freespace_downsampling:
            mask = np.zeros_like(free)
            mask[::2, ::2] = free[::2, ::2]
        rows, cols = np.nonzero(mask)
        centres = np.column_stack((origin.x + (cols + 0.5) * res, origin.y + (rows + 0.5) * res))
        return AmclMap(state, np.ascontiguousarray(dist), centres.astype(np.float64), res,
                       origin.x, origin.y, float(max_occ_dist))


@dataclass(frozen=True, eq=False)
class LaserData:
    """The beams of one scan that enter the update, in the robot base frame.

    ``ranges`` [m] and ``bearings`` [rad, base frame] of the subsampled valid beams;
    ``laser_xy`` the laser's position in the base frame; ``range_max`` the effective
    maximum range; ``invalid`` how many subsampled beams were NaN/-inf.
    """

    ranges: FloatArray
    bearings: FloatArray
    laser_xy: tuple[float, float]
    range_max: float
    invalid: int


def prepare_scan(ranges: NDArray[np.floating], angle_min: float, angle_increment: float,
                 scan_range_min: float, scan_range_max: float,
                 laser_pose_base: tuple[float, float, float], params: AmclParams) -> LaserData:
    """Subsample to ``max_beams``, apply Nav2's range limits and drop invalid readings.

    ``range_max = min(scan.range_max, laser_max_range)`` when ``laser_max_range > 0``,
    ``range_min = max(scan.range_min, laser_min_range)`` when ``laser_min_range > 0``
    (amcl's ``updateFilter``).  ``laser_pose_base`` is the laser's ``(x, y, yaw)`` in the
    base frame: bearings are turned into the base frame by its yaw.
    """
    p = params
    range_max = (min(scan_range_max, p.laser_max_range) if p.laser_max_range > 0.0
                 else scan_range_max)
    range_min = (max(scan_range_min, p.laser_min_range) if p.laser_min_range > 0.0
                 else scan_range_min)
    r = np.asarray(ranges, np.float64)
    count = len(r)
    step = max(1, (count - 1) // (p.max_beams - 1)) if count > 1 else 1
    idx = np.arange(0, count, step)
    obs = r[idx].copy()
    bearings = laser_pose_base[2] + angle_min + idx * angle_increment
    valid = ~np.isnan(obs) & (obs > -np.inf)
    obs[obs <= range_min] = range_max  # amcl has no min range: short readings are max
    obs = np.minimum(obs, range_max)  # +inf (no return) and overlong readings: max range
    return LaserData(np.ascontiguousarray(obs[valid]), np.ascontiguousarray(bearings[valid]),
                     (laser_pose_base[0], laser_pose_base[1]), float(range_max),
                     int(np.count_nonzero(~valid)))


# --- numba kernels -------------------------------------------------------------------------
@numba.njit(cache=True, inline="always")
def _cell_value(table: FloatArray, i: int, j: int, off_map: float) -> float:
    h, w = table.shape
    if i < 0 or j < 0 or i >= w or j >= h:
        return off_map
    return float(table[j, i])


@numba.njit(cache=True)
def _bilinear(table: FloatArray, gx: float, gy: float, off_map: float) -> float:
    """``table`` bilinearly interpolated between cell centres at the grid point
    ``(gx, gy)`` (cell units from the map origin); neighbours off the map count as
    ``off_map``.

    amcl reads the value of the cell an end point falls in.  With the obstacle distance
    measured between cell centres that biases the estimate by up to half a cell: an end
    point on a wall face that is a cell boundary reads 0 from one side and one cell from
    the other, so a corridor's two walls pull unequally.  Interpolating between the
    centres makes the two faces of a wall symmetric (docs/localization.md)."""
    u = gx - 0.5
    v = gy - 0.5
    i0 = math.floor(u)
    j0 = math.floor(v)
    fx = u - i0
    fy = v - j0
    a = _cell_value(table, i0, j0, off_map)
    b = _cell_value(table, i0 + 1, j0, off_map)
    c = _cell_value(table, i0, j0 + 1, off_map)
    d = _cell_value(table, i0 + 1, j0 + 1, off_map)
    return (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy


@numba.njit(cache=True)
def _field_sum(poses: FloatArray, lx: float, ly: float, bx: FloatArray, by: FloatArray,
               table: FloatArray, off_map: float) -> FloatArray:
    """Per particle, ``sum_j table(end point j)`` (:func:`_bilinear`).

    ``table`` holds a per-cell function of the clamped obstacle distance (``pz^3`` or
    ``log pz``), so a beam costs four lookups and no exponential; poses, laser offset
    ``(lx, ly)`` and end points ``(bx, by)`` (laser-relative, base-frame axes) are in cell
    units relative to the map origin, and each particle needs one sin/cos."""
    n, b = poses.shape[0], bx.shape[0]
    out = np.empty(n)
    for i in range(n):
        c, s = math.cos(poses[i, 2]), math.sin(poses[i, 2])
        sx = poses[i, 0] + c * lx - s * ly
        sy = poses[i, 1] + s * lx + c * ly
        total = 0.0
        for j in range(b):
            total += _bilinear(table, sx + c * bx[j] - s * by[j], sy + s * bx[j] + c * by[j],
                               off_map)
        out[i] = total
    return out


@numba.njit(cache=True)
def _field_matrix(poses: FloatArray, lx: float, ly: float, bx: FloatArray, by: FloatArray,
                  table: FloatArray, off_map: float, near: NDArray[np.bool_]
                  ) -> tuple[FloatArray, NDArray[np.int64]]:
    """``(N, B)`` per-beam values of ``table`` (as :func:`_field_sum`, not summed) and,
    per beam, how many particles put its end point on a ``near`` cell (beam skipping's
    agreement count; off-map end points never agree)."""
    n, b = poses.shape[0], bx.shape[0]
    h, w = table.shape
    out = np.empty((n, b))
    agree = np.zeros(b, np.int64)
    for i in range(n):
        c, s = math.cos(poses[i, 2]), math.sin(poses[i, 2])
        sx = poses[i, 0] + c * lx - s * ly
        sy = poses[i, 1] + s * lx + c * ly
        for j in range(b):
            gx = sx + c * bx[j] - s * by[j]
            gy = sy + s * bx[j] + c * by[j]
            out[i, j] = _bilinear(table, gx, gy, off_map)
            mi = math.floor(gx)
            mj = math.floor(gy)
            if 0 <= mi < w and 0 <= mj < h and near[mj, mi]:
                agree[j] += 1
    return out, agree


@numba.njit(cache=True)
def ray_range(occ_state: NDArray[np.int8], ox: float, oy: float, res: float, x0: float,
              y0: float, dx: float, dy: float, max_range: float) -> float:
    """Distance along the unit direction ``(dx, dy)`` from ``(x0, y0)`` to the first cell
    that is not free (occupied, unknown or off the map), capped at ``max_range``.

    An exact grid traversal (Amanatides & Woo, "A fast voxel traversal algorithm", 1987)
    in place of amcl's Bresenham ``map_calc_range``; a start outside free space gives 0."""
    h, w = occ_state.shape
    gx, gy = (x0 - ox) / res, (y0 - oy) / res
    ci, cj = math.floor(gx), math.floor(gy)
    if ci < 0 or cj < 0 or ci >= w or cj >= h or occ_state[cj, ci] != -1:
        return 0.0
    step_i = 1 if dx > 0.0 else -1
    step_j = 1 if dy > 0.0 else -1
    t_di = res / abs(dx) if dx != 0.0 else math.inf
    t_dj = res / abs(dy) if dy != 0.0 else math.inf
    t_i = math.inf
    t_j = math.inf
    if dx != 0.0:
        t_i = ((ci + 1 - gx) if dx > 0.0 else (gx - ci)) * t_di
    if dy != 0.0:
        t_j = ((cj + 1 - gy) if dy > 0.0 else (gy - cj)) * t_dj
    while True:
        if t_i < t_j:
            t = t_i
            ci += step_i
            t_i += t_di
        else:
            t = t_j
            cj += step_j
            t_j += t_dj
        if t >= max_range:
            return max_range
        if ci < 0 or cj < 0 or ci >= w or cj >= h or occ_state[cj, ci] != -1:
            return t


@numba.njit(cache=True)
def _beam_cube(poses: FloatArray, lx: float, ly: float, obs: FloatArray, cb: FloatArray,
               sb: FloatArray, occ_state: NDArray[np.int8], ox: float, oy: float,
               res: float, range_max: float, z_hit: float, z_short: float, z_max: float,
               z_rand: float, sigma_hit: float, lambda_short: float) -> FloatArray:
    """``1 + sum pz^3`` of amcl's ``BeamModel`` for every particle (``cb, sb``: cosine
    and sine of the beam bearings in the base frame)."""
    n, b = poses.shape[0], obs.shape[0]
    out = np.empty(n)
    denom = 2.0 * sigma_hit * sigma_hit
    for i in range(n):
        c, s = math.cos(poses[i, 2]), math.sin(poses[i, 2])
        sx = poses[i, 0] + c * lx - s * ly
        sy = poses[i, 1] + s * lx + c * ly
        p = 1.0
        for j in range(b):
            expected = ray_range(occ_state, ox, oy, res, sx, sy, c * cb[j] - s * sb[j],
                                 s * cb[j] + c * sb[j], range_max)
            z = obs[j] - expected
            pz = z_hit * math.exp(-z * z / denom)
            if z < 0.0:
                pz += z_short * lambda_short * math.exp(-lambda_short * obs[j])
            if obs[j] >= range_max:
                pz += z_max
            else:
                pz += z_rand / range_max
            p += pz * pz * pz
        out[i] = p
    return out


class LaserModel:
    """The ``laser_model_type`` measurement model over one :class:`AmclMap`.

    :meth:`log_likelihood` returns ``log p(z | x)`` per particle (the cube-sum models'
    ``log(1 + sum pz^3)``, the product model's ``sum log pz``), so the filter can weight
    in log space whatever the number of beams.  The likelihood field's per-cell ``pz``
    depends only on the cell (and the scan's ``range_max`` through ``z_rand``), so it is
    tabulated once per ``range_max``.  After a ``likelihood_field_prob`` update
    ``skipped_beams`` and ``beamskip_error`` tell what beam skipping did, and
    ``factors`` how many per-beam factors the product had (1 for the cube-sum models,
    whose ``1 + sum pz^3`` is one bounded score per scan).
    """

    def __init__(self, params: AmclParams, amcl_map: AmclMap) -> None:
        self.params = params
        self.map = amcl_map
        self.factors = 1
        self.skipped_beams = 0
        self.beamskip_error = False
        self._tables: dict[float, tuple[FloatArray, float]] = {}
        self._near = amcl_map.occ_dist < params.beam_skip_distance

    def beam_probability(self, distance: FloatArray | float, range_max: float
                         ) -> FloatArray:
        """Likelihood-field ``pz`` of end points at ``distance`` [m] from the nearest
        obstacle: ``z_hit exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max``."""
        p = self.params
        d = np.asarray(distance, np.float64)
        return np.asarray(p.z_hit * np.exp(-d * d / (2.0 * p.sigma_hit * p.sigma_hit))
                          + p.z_rand / range_max)

    def _table(self, range_max: float) -> tuple[FloatArray, float]:
        """Per-cell ``pz^3`` (cube models) or ``log pz`` (prob model), and the off-map
        value (``pz`` at ``laser_likelihood_max_dist``), for one ``range_max``."""
        cached = self._tables.get(range_max)
        if cached is None:
            pz = self.beam_probability(self.map.occ_dist, range_max)  # > 0 unless z_rand 0
            far = float(self.beam_probability(self.map.max_occ_dist, range_max))
            if self.params.laser_model_type == "likelihood_field":
                cached = (np.ascontiguousarray(pz ** 3), far ** 3)
            else:
                with np.errstate(divide="ignore"):
                    cached = (np.ascontiguousarray(np.log(pz)),
                              math.log(far) if far > 0.0 else -math.inf)
            if len(self._tables) > 4:
                self._tables.clear()
            self._tables[range_max] = cached
        return cached

    def log_likelihood(self, poses: FloatArray, scan: LaserData,
                       converged: bool = False) -> FloatArray:
        """``(N,)`` log-likelihood of ``scan`` for particle poses ``(N, 3)`` in the map
        frame; ``converged`` (the filter's flag) enables beam skipping."""
        p, m = self.params, self.map
        poses = np.ascontiguousarray(poses, np.float64)
        lx, ly = scan.laser_xy
        self.skipped_beams = 0
        self.beamskip_error = False
        if p.laser_model_type == "beam":
            out = _beam_cube(poses, lx, ly, scan.ranges, np.cos(scan.bearings),
                             np.sin(scan.bearings), m.occ_state, m.origin_x, m.origin_y,
                             m.resolution, scan.range_max, p.z_hit, p.z_short, p.z_max,
                             p.z_rand, p.sigma_hit, p.lambda_short)
            return np.log(out)
        keep = scan.ranges < scan.range_max  # the likelihood field ignores max readings
        r, a = scan.ranges[keep], scan.bearings[keep]
        inv = 1.0 / m.resolution
        bx = np.ascontiguousarray(r * np.cos(a) * inv)
        by = np.ascontiguousarray(r * np.sin(a) * inv)
        grid_poses = np.column_stack(((poses[:, 0] - m.origin_x) * inv,
                                      (poses[:, 1] - m.origin_y) * inv, poses[:, 2]))
        table, off_map = self._table(scan.range_max)
        if p.laser_model_type == "likelihood_field":
            return np.log1p(_field_sum(grid_poses, lx * inv, ly * inv, bx, by, table, off_map))
        log_pz, agree = _field_matrix(grid_poses, lx * inv, ly * inv, bx, by, table, off_map,
                                      self._near)
        self.factors = max(int(log_pz.shape[1]), 1)
        if not (p.do_beamskip and converged) or len(poses) == 0:
            return log_pz.sum(axis=1)
        use = agree / len(poses) > p.beam_skip_threshold
        skipped = int(np.count_nonzero(~use))
        self.skipped_beams = skipped
        if skipped >= len(use) * p.beam_skip_error_threshold:
            self.beamskip_error = True  # most beams disagree: probably converged wrongly
            return log_pz.sum(axis=1)
        self.factors = max(int(np.count_nonzero(use)), 1)
        return log_pz[:, use].sum(axis=1)

"""Simulated multi-ring lidar (Velodyne VLP-16 class): an organised ``PointCloud2``.

The world is 2-D, so it is extruded for this sensor: every occupied cell is a column
of ``heights[row, col]`` metres (one ``obstacle_height`` unless a height map is given),
moving obstacles are ``moving_obstacle_height`` tall, and the ground is the plane
z = 0 of ``base_link``.  Per azimuth the kernel walks the grid cells in the horizontal
plane exactly like the planar ray caster (Amanatides & Woo 1987, see
:mod:`navstack.sim.raycast`) and, for every ring, checks the height of the ray inside
each occupied cell: a ring whose height at the cell's entry lies within the column hits
its vertical face -- at the same horizontal distance the planar lidar reports -- and a
descending ring that is above the column at entry but below its top at exit lands on
its top.  A descending ring hits the ground at ``z_sensor / tan(-elevation)`` if nothing
is nearer; an ascending ring passes over everything lower than itself.

Points are ``(x, y, z)`` in the sensor frame with fields ``x y z intensity ring``
(float32 and uint16, the velodyne driver's layout); a ring that returns nothing gives a
NaN point (``is_dense`` false), keeping the cloud organised (rings x azimuths).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from navstack.core.msgs import Header, PointCloud2
from navstack.sim.raycast import _circle_hit, _segment_hit
from navstack.sim.robot import Lidar3dParams

__all__ = ["Lidar3dModel", "cast_cloud"]

FloatArray = NDArray[np.float64]
_NO = np.zeros((0, 3), dtype=np.float64)
_NO_SEG = np.zeros((0, 4), dtype=np.float64)


@njit(cache=True, nogil=True)
def _cloud_kernel(occ: NDArray[np.bool_], heights: FloatArray, origin_x: float,
                  origin_y: float, res: float, x: float, y: float, z: float, yaw: float,
                  azimuths: FloatArray, slopes: FloatArray, range_max_h: float,
                  circles: FloatArray, segments: FloatArray, moving_h: float,
                  out: FloatArray) -> None:
    """``out[k, j]``: horizontal distance [m] of ring ``k`` at azimuth ``j`` (inf: none)."""
    h_rows, w = occ.shape
    n_rings = slopes.shape[0]
    gx, gy = (x - origin_x) / res, (y - origin_y) / res
    max_t = range_max_h / res
    for j in range(azimuths.shape[0]):
        a = yaw + azimuths[j]
        dx, dy = math.cos(a), math.sin(a)
        best = np.empty(n_rings)
        for k in range(n_rings):  # the ground, for descending rings
            best[k] = -z / slopes[k] if slopes[k] < 0.0 else math.inf
        # moving obstacles: one horizontal distance each, then the height test per ring
        tm = math.inf
        if circles.shape[0] > 0:
            tm = _circle_hit(x, y, dx, dy, circles, tm)
        if segments.shape[0] > 0:
            tm = _segment_hit(x, y, dx, dy, segments, tm)
        if tm < math.inf:
            for k in range(n_rings):
                zk = z + slopes[k] * tm
                if 0.0 <= zk <= moving_h and tm < best[k]:
                    best[k] = tm
        # the grid walk (only inside the grid; outside is free space)
        if 0.0 <= gx < w and 0.0 <= gy < h_rows:
            ix, iy = math.floor(gx), math.floor(gy)
            if dx > 0.0:
                sx, tmx, tdx = 1, (ix + 1 - gx) / dx, 1.0 / dx
            elif dx < 0.0:
                sx, tmx, tdx = -1, (ix - gx) / dx, -1.0 / dx
            else:
                sx, tmx, tdx = 0, math.inf, math.inf
            if dy > 0.0:
                sy, tmy, tdy = 1, (iy + 1 - gy) / dy, 1.0 / dy
            elif dy < 0.0:
                sy, tmy, tdy = -1, (iy - gy) / dy, -1.0 / dy
            else:
                sy, tmy, tdy = 0, math.inf, math.inf
            t_in = 0.0
            while t_in <= max_t:
                t_out = min(tmx, tmy)
                if occ[iy, ix]:
                    hc = heights[iy, ix]
                    d_in, d_out = t_in * res, t_out * res
                    done = True
                    for k in range(n_rings):
                        if best[k] <= d_in:
                            continue
                        done = False
                        z_in = z + slopes[k] * d_in
                        z_out = z + slopes[k] * d_out
                        if 0.0 <= z_in <= hc:
                            best[k] = d_in
                        elif z_in > hc >= z_out:  # lands on the top
                            best[k] = min(best[k], (hc - z) / slopes[k])
                    if done:
                        break
                if tmx < tmy:
                    ix += sx
                    t_in = tmx
                    tmx += tdx
                else:
                    iy += sy
                    t_in = tmy
                    tmy += tdy
                if ix < 0 or ix >= w or iy < 0 or iy >= h_rows:
                    break
        for k in range(n_rings):
            out[k, j] = best[k]


def cast_cloud(occupied: NDArray[np.bool_], heights: FloatArray, origin_x: float,
               origin_y: float, resolution: float, sensor_xyz: tuple[float, float, float],
               yaw: float, azimuths: FloatArray, elevations: FloatArray, range_max: float,
               circles: FloatArray | None = None, segments: FloatArray | None = None,
               moving_height: float = 1.7) -> FloatArray:
    """Horizontal distances ``(rings, azimuths)`` [m] from a sensor at ``sensor_xyz``
    (z above the ground) heading ``yaw``; ``inf`` where a ring returns nothing within
    ``range_max`` (measured along the beam)."""
    slopes = np.tan(np.asarray(elevations, dtype=np.float64))
    out = np.empty((len(slopes), len(azimuths)), dtype=np.float64)
    x, y, z = sensor_xyz
    _cloud_kernel(np.ascontiguousarray(occupied), np.ascontiguousarray(heights, np.float64),
                  float(origin_x), float(origin_y), float(resolution), float(x), float(y),
                  float(z), float(yaw), np.asarray(azimuths, np.float64), slopes,
                  float(range_max), _NO if circles is None else circles,
                  _NO_SEG if segments is None else segments, float(moving_height), out)
    beam = out / np.cos(np.asarray(elevations, np.float64))[:, None]
    out[beam > range_max] = np.inf
    return out


class Lidar3dModel:
    """Ring geometry, noise and the ``PointCloud2`` of a multi-ring lidar."""

    def __init__(self, params: Lidar3dParams) -> None:
        self.params = p = params
        self.elevations = np.linspace(p.elevation_min, p.elevation_max, p.rings)
        self.azimuths = -math.pi + 2.0 * math.pi * np.arange(p.azimuths) / p.azimuths
        self.mount = p.mount

    def cloud(self, distances: FloatArray, now: float, rng: np.random.Generator | None = None
              ) -> PointCloud2:
        """The cloud for horizontal distances ``(rings, azimuths)`` from :func:`cast_cloud`."""
        p = self.params
        el = self.elevations[:, None]
        r = distances / np.cos(el)
        if p.noise_std > 0.0 and rng is not None:
            r = r + p.noise_std * rng.standard_normal(r.shape)
        valid = np.isfinite(r) & (r >= p.range_min) & (r <= p.range_max)
        r = np.where(valid, r, np.nan)
        az = self.azimuths[None, :]
        xs = (r * np.cos(el) * np.cos(az)).astype(np.float32)
        ys = (r * np.cos(el) * np.sin(az)).astype(np.float32)
        zs = (r * np.sin(el) * np.ones_like(az)).astype(np.float32)
        ring = np.repeat(np.arange(p.rings, dtype=np.uint16), p.azimuths)
        intensity = np.where(valid, 100.0, 0.0).astype(np.float32)
        return PointCloud2.from_fields(Header(now, p.frame_id), {
            "x": xs.reshape(-1), "y": ys.reshape(-1), "z": zs.reshape(-1),
            "intensity": intensity.reshape(-1), "ring": ring}, height=p.rings)

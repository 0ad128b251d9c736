"""Pure metric functions of ``navstack report`` (numpy in, numbers out; no bag, no I/O).

* Path length on a fixed sampling grid (:func:`grid_path`): the trajectory is linearly
  interpolated at the multiples of ``period`` inside a time window and the polyline of
  those samples is measured -- exactly what the demo's ``TrajectoryRecorder`` (true pose
  every 0.1 s from t = 0) measures, so a recorded demo reproduces ``report.json``.
* Latency-aware safe speed (:func:`safe_speed`): the robot must stop within the free
  distance ``d`` after reacting ``L`` seconds late and braking at ``a``:
  ``v L + v^2 / (2 a) = d``  =>  ``v_max = -a L + sqrt(a^2 L^2 + 2 a d)``.
* End-to-end latency (:func:`scan_to_cmd_latency`): for every scan taken while commands
  flow, the first command logged strictly after the scan minus the scan's header stamp
  -- sensor stamping, transport, perception, planning and control together.
* Clearance (:func:`static_clearances`, :func:`moving_clearances`): the demo's
  definition -- distance from the robot's footprint outline at each sampled pose to the
  nearest occupied map cell (its square) and, separately, to the nearest moving obstacle,
  0 on contact, capped at :data:`~navstack.sim.collision.CLEARANCE_CAP`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import distance_transform_edt

from navstack.core.msgs import Marker, MarkerArray, OccupancyGrid
from navstack.sim.collision import (
    CLEARANCE_CAP,
    grid_clearance,
    grid_polygon_clearance,
    moving_clearance,
    polygon_hits_grid,
)

FloatArray = NDArray[np.float64]

#: Nav2 map_server ``occupied_thresh`` (0.65) on the 0..100 occupancy scale
OCCUPIED = 65


def stats(values: FloatArray) -> dict[str, float]:
    """``mean``, ``median``, ``p95`` and ``max`` of ``values`` (NaN when empty)."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"mean": math.nan, "median": math.nan, "p95": math.nan, "max": math.nan}
    return {"mean": float(v.mean()), "median": float(np.median(v)),
            "p95": float(np.percentile(v, 95)), "max": float(v.max())}


def path_length(xy: FloatArray) -> float:
    """Length [m] of the polyline through the ``(N, 2)`` points."""
    if len(xy) < 2:
        return 0.0
    d = np.diff(np.asarray(xy, dtype=np.float64), axis=0)
    return float(np.sum(np.hypot(d[:, 0], d[:, 1])))


def grid_times(t0: float, t1: float, period: float, tol: float = 1e-6) -> FloatArray:
    """Multiples of ``period`` in ``[t0 - tol, t1 + tol]``."""
    if t1 < t0:
        return np.zeros(0)
    k0 = math.ceil((t0 - tol) / period)
    k1 = math.floor((t1 + tol) / period)
    return np.arange(k0, k1 + 1, dtype=np.float64) * period


def interpolate_xy(t: FloatArray, xy: FloatArray, at: FloatArray) -> FloatArray:
    """Positions at times ``at`` by linear interpolation (clamped at both ends)."""
    return np.column_stack((np.interp(at, t, xy[:, 0]), np.interp(at, t, xy[:, 1])))


def grid_path(t: FloatArray, xy: FloatArray, t0: float, t1: float,
              period: float) -> FloatArray:
    """The ``(K, 2)`` trajectory samples on the ``period`` grid within ``[t0, t1]``."""
    if len(t) == 0:
        return np.zeros((0, 2))
    return interpolate_xy(t, xy, grid_times(t0, t1, period))


def curvature(v: FloatArray, w: FloatArray, v_min: float = 0.05) -> FloatArray:
    """Path curvature ``|w| / |v|`` [1/m] of the samples moving faster than ``v_min``."""
    v = np.abs(np.asarray(v, dtype=np.float64))
    w = np.abs(np.asarray(w, dtype=np.float64))
    moving = v > v_min
    return w[moving] / v[moving]


def scan_to_cmd_latency(scan_log_t: FloatArray, scan_stamp: FloatArray,
                        cmd_log_t: FloatArray, active_window: float = 1.0) -> FloatArray:
    """Per scan: log time of the first command logged after it minus its stamp [s].

    Only scans taken while commands flow count -- commands logged within
    ``active_window`` s before and after the scan -- so the idle time between goals is
    not taken for latency.  ``cmd_log_t`` must be sorted.
    """
    cmd = np.asarray(cmd_log_t, dtype=np.float64)
    scan_t = np.asarray(scan_log_t, dtype=np.float64)
    if cmd.size == 0 or scan_t.size == 0:
        return np.zeros(0)
    nxt = np.searchsorted(cmd, scan_t, side="right")
    prev = nxt - 1
    ok = (nxt < cmd.size) & (prev >= 0)
    ok[ok] &= (scan_t[ok] - cmd[prev[ok]] <= active_window) & \
        (cmd[nxt[ok]] - scan_t[ok] <= active_window)
    return cmd[nxt[ok]] - np.asarray(scan_stamp, dtype=np.float64)[ok]


def forward_free_distance(ranges: NDArray[np.floating], angles: FloatArray,
                          range_min: float, range_max: float, half_angle: float) -> float:
    """Smallest valid range [m] among beams within ``half_angle`` of straight ahead
    (``angles`` already in the base frame); ``range_max`` when nothing is in the sector."""
    r = np.asarray(ranges, dtype=np.float64)
    sector = np.abs(np.arctan2(np.sin(angles), np.cos(angles))) <= half_angle
    valid = sector & np.isfinite(r) & (r >= range_min) & (r <= range_max)
    return float(r[valid].min()) if valid.any() else float(range_max)


def safe_speed(decel: float, latency: float | FloatArray,
               free: float | FloatArray) -> FloatArray:
    """``v_max = -a L + sqrt(a^2 L^2 + 2 a d)`` [m/s] (0 where ``d <= 0``)."""
    a = float(decel)
    lat = np.asarray(latency, dtype=np.float64)
    d = np.maximum(np.asarray(free, dtype=np.float64), 0.0)
    return np.asarray(-a * lat + np.sqrt(a * a * lat * lat + 2.0 * a * d), dtype=np.float64)


def clearance_field(grid: OccupancyGrid) -> FloatArray:
    """Distance [m] from every cell centre to the nearest occupied cell's centre
    (``inf`` everywhere when the map has no occupied cell)."""
    occupied = np.asarray(grid.data) >= OCCUPIED
    if not occupied.any():
        return np.full(occupied.shape, np.inf)
    field: FloatArray = distance_transform_edt(~occupied) * grid.info.resolution
    return field


def clearance_at(grid: OccupancyGrid, field: FloatArray, xy: FloatArray) -> FloatArray:
    """Clearance [m] of the map-frame points ``xy`` (NaN outside the map)."""
    o = grid.info.origin.to_pose2d()
    res = grid.info.resolution
    c, s = math.cos(o.theta), math.sin(o.theta)
    dx, dy = xy[:, 0] - o.x, xy[:, 1] - o.y
    col = np.floor((c * dx + s * dy) / res).astype(np.int64)
    row = np.floor((-s * dx + c * dy) / res).astype(np.int64)
    h, w = field.shape
    inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
    out = np.full(len(xy), np.nan)
    out[inside] = field[row[inside], col[inside]]
    return out


def interpolate_yaw(t: FloatArray, yaw: FloatArray, at: FloatArray) -> FloatArray:
    """Headings at times ``at`` (linear on the unwrapped angle, clamped at both ends)."""
    return np.asarray(np.interp(at, t, np.unwrap(yaw)), dtype=np.float64)


def _grid_frame(grid: OccupancyGrid, xy: FloatArray, yaw: FloatArray
                ) -> tuple[FloatArray, FloatArray]:
    """Poses in the grid's own axes (origin rotation removed; distances unchanged)."""
    o = grid.info.origin.to_pose2d()
    c, s = math.cos(o.theta), math.sin(o.theta)
    dx, dy = xy[:, 0] - o.x, xy[:, 1] - o.y
    return np.column_stack((c * dx + s * dy, -s * dx + c * dy)), yaw - o.theta


def _place(footprint: FloatArray, x: float, y: float, yaw: float) -> FloatArray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.ascontiguousarray(np.column_stack(
        (x + c * footprint[:, 0] - s * footprint[:, 1],
         y + s * footprint[:, 0] + c * footprint[:, 1])), dtype=np.float64)


def static_clearances(grid: OccupancyGrid, xy: FloatArray, yaw: FloatArray,
                      footprint: FloatArray | None, radius: float = 0.0,
                      cap: float = CLEARANCE_CAP) -> FloatArray:
    """Per pose: distance [m] from the footprint (``(N, 2)`` in the robot frame, or a
    circle of ``radius`` when ``None``) to the nearest occupied cell square of ``grid``
    (occupancy >= :data:`OCCUPIED`), capped at ``cap``; 0 on contact."""
    occ = np.ascontiguousarray(np.asarray(grid.data).reshape(grid.info.height,
                                                            grid.info.width) >= OCCUPIED)
    res = float(grid.info.resolution)
    pts, headings = _grid_frame(grid, np.asarray(xy, dtype=np.float64).reshape(-1, 2),
                                np.asarray(yaw, dtype=np.float64))
    out = np.empty(len(pts))
    for i, ((x, y), h) in enumerate(zip(pts, headings, strict=True)):
        if footprint is None:
            d = grid_clearance(occ, 0.0, 0.0, res, float(x), float(y), cap + radius)
            out[i] = min(max(d - radius, 0.0), cap)
            continue
        poly = _place(footprint, float(x), float(y), float(h))
        out[i] = (0.0 if polygon_hits_grid(occ, 0.0, 0.0, res, poly)
                  else grid_polygon_clearance(occ, 0.0, 0.0, res, poly, cap))
    return out


def obstacle_shapes(markers: MarkerArray) -> tuple[FloatArray, FloatArray]:
    """``(circles (k, 3), boxes (b, 4, 2))`` of a ``/sim/obstacles`` MarkerArray."""
    circles, boxes = [], []
    for m in markers.markers:
        p, h = m.pose.position, m.pose.orientation.yaw
        if m.type == Marker.CYLINDER:
            circles.append((p.x, p.y, 0.5 * m.scale.x))
        elif m.type == Marker.CUBE:
            hl, hw = 0.5 * m.scale.x, 0.5 * m.scale.y
            local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
            boxes.append(_place(local, p.x, p.y, h))
    return (np.array(circles, dtype=np.float64).reshape(-1, 3),
            np.array(boxes, dtype=np.float64).reshape(-1, 4, 2))


def moving_clearances(t: FloatArray, xy: FloatArray, yaw: FloatArray,
                      footprint: FloatArray | None, radius: float,
                      obstacle_t: FloatArray, obstacles: list[tuple[FloatArray, FloatArray]],
                      cap: float = CLEARANCE_CAP) -> FloatArray:
    """Per pose at time ``t``: distance [m] from the footprint (or a ``radius`` circle) to
    the moving obstacles of the latest ``obstacles`` sample at or before ``t`` (NaN before
    the first), capped at ``cap``; 0 on contact."""
    out = np.full(len(t), np.nan)
    idx = np.searchsorted(obstacle_t, np.asarray(t) + 1e-9, side="right") - 1
    body = footprint if footprint is not None else np.zeros((1, 2))
    none = np.zeros((0, 3)), np.zeros((0, 4, 2))
    for i in range(len(t)):
        if idx[i] < 0:
            continue
        circles, boxes = obstacles[idx[i]]
        poly = _place(body, float(xy[i, 0]), float(xy[i, 1]), float(yaw[i]))
        if footprint is not None:
            d = moving_clearance(poly, circles, boxes, cap)
        else:  # a circle of `radius`: grow the round obstacles, shrink the box distance
            grown = circles.copy()
            grown[:, 2] += radius
            d = min(moving_clearance(poly, grown, none[1], cap),
                    moving_clearance(poly, none[0], boxes, cap + radius) - radius)
        out[i] = min(max(d, 0.0), cap)
    return out

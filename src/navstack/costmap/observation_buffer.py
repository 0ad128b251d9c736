"""Observation sources of the obstacle layer (Nav2 ``ObservationBuffer`` semantics).

An :class:`Observation` is a point cloud in the costmap's frame plus the sensor origin and
the range limits of its source.  Scans are projected here, vectorised over beams:

* finite ranges within ``[range_min, range_max]`` become points at the sensor height;
* with ``inf_is_valid``, ``+inf`` ranges become *clearing-only* rays of
  ``raytrace_max_range`` (they clear free space but never mark).  Nav2 instead rewrites
  them to ``range_max - 1e-4`` m, which can mark phantom obstacles when
  ``obstacle_max_range > range_max``; the clearing-only form avoids that;
* NaN, ``-inf`` and out-of-limit ranges are dropped.

Per-source ``min_obstacle_height``/``max_obstacle_height`` filter points by z when they
are buffered (so a filtered point neither marks nor clears, as in Nav2).  Note Nav2's
per-source default ``max_obstacle_height`` is 0.0, which drops every return of a sensor
mounted above the ground: set it (Nav2's example params use 2.0).

``observation_persistence`` [s]: 0 keeps only the latest observation, which is re-applied
every update until a newer one arrives; otherwise observations younger than it are all
applied.  ``expected_update_rate`` is, as in Nav2, a *period* [s]: the source is current
while ``now - last_update <= expected_update_rate`` (0 disables the check).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from navstack.core.msgs import LaserScan, Pose2D
from navstack.core.params import Params


class ObservationSourceParams(Params):
    """Per-source obstacle layer parameters (Nav2 names and defaults)."""

    topic: str = ""
    sensor_frame: str = ""
    observation_persistence: float = Field(0.0, ge=0.0)
    expected_update_rate: float = Field(0.0, ge=0.0)
    data_type: Literal["LaserScan", "PointCloud2"] = "LaserScan"
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 0.0
    inf_is_valid: bool = False
    marking: bool = True
    clearing: bool = False
    obstacle_max_range: float = Field(2.5, ge=0.0)
    obstacle_min_range: float = Field(0.0, ge=0.0)
    raytrace_max_range: float = Field(3.0, ge=0.0)
    raytrace_min_range: float = Field(0.0, ge=0.0)


def _empty3() -> NDArray[np.float64]:
    return np.zeros((0, 3))


@dataclass(frozen=True, eq=False)
class Observation:
    """Points seen from ``origin``, all in the costmap frame [m].

    ``points`` ``(N, 3)`` mark and clear; ``clear_only`` ``(M, 3)`` only clear (inf beams).
    """

    stamp: float
    origin: NDArray[np.float64]
    points: NDArray[np.float64]
    clear_only: NDArray[np.float64] = field(default_factory=_empty3)
    obstacle_max_range: float = 2.5
    obstacle_min_range: float = 0.0
    raytrace_max_range: float = 3.0
    raytrace_min_range: float = 0.0


def filter_height(xyz: NDArray[np.float64], params: ObservationSourceParams
                  ) -> NDArray[np.float64]:
    z = xyz[:, 2]
    return xyz[(z >= params.min_obstacle_height) & (z <= params.max_obstacle_height)]


def observation_from_points(xyz: ArrayLike, sensor_origin: ArrayLike,
                            params: ObservationSourceParams, stamp: float = 0.0
                            ) -> Observation:
    """An observation from ``(N, 3)`` points already in the costmap frame."""
    pts = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    origin = np.asarray(sensor_origin, dtype=np.float64).reshape(3)
    return Observation(stamp, origin, filter_height(pts, params),
                       obstacle_max_range=params.obstacle_max_range,
                       obstacle_min_range=params.obstacle_min_range,
                       raytrace_max_range=params.raytrace_max_range,
                       raytrace_min_range=params.raytrace_min_range)


def observation_from_scan(scan: LaserScan, sensor_pose: Pose2D, sensor_z: float,
                          params: ObservationSourceParams, inf_ray_length: float
                          ) -> Observation:
    """Project ``scan`` taken at ``sensor_pose`` (costmap frame) at height ``sensor_z``.

    ``inf_ray_length`` [m] is where clearing-only rays of ``+inf`` beams end (the obstacle
    layer passes ``raytrace_max_range`` plus a cell so the whole range is cleared).
    """
    r = np.asarray(scan.ranges, dtype=np.float64)
    ang = sensor_pose.theta + scan.angle_min + scan.angle_increment * np.arange(len(r))
    ok = np.isfinite(r) & (r >= scan.range_min) & (r <= scan.range_max)
    c, s = np.cos(ang), np.sin(ang)
    pts = np.column_stack((sensor_pose.x + r[ok] * c[ok], sensor_pose.y + r[ok] * s[ok],
                           np.full(int(ok.sum()), sensor_z)))
    if params.inf_is_valid:
        inf = np.isposinf(r)
        n_inf = int(inf.sum())
        clear = np.column_stack((sensor_pose.x + inf_ray_length * c[inf],
                                 sensor_pose.y + inf_ray_length * s[inf],
                                 np.full(n_inf, sensor_z)))
        clear = filter_height(clear, params)
    else:
        clear = _empty3()
    origin = np.array([sensor_pose.x, sensor_pose.y, sensor_z])
    return Observation(scan.header.stamp, origin, filter_height(pts, params), clear,
                       params.obstacle_max_range, params.obstacle_min_range,
                       params.raytrace_max_range, params.raytrace_min_range)


class ObservationBuffer:
    """Time-bounded store of one source's observations (Nav2 ``ObservationBuffer``)."""

    def __init__(self, name: str, params: ObservationSourceParams) -> None:
        self.name = name
        self.params = params
        self._obs: deque[Observation] = deque()
        self.last_updated: float | None = None

    def add(self, obs: Observation) -> None:
        self._obs.appendleft(obs)  # newest first, as Nav2's list
        self.last_updated = obs.stamp
        self.purge(obs.stamp)

    def purge(self, now: float) -> None:
        if not self._obs:
            return
        if self.params.observation_persistence == 0.0:
            while len(self._obs) > 1:
                self._obs.pop()
            return
        while self._obs and now - self._obs[-1].stamp > self.params.observation_persistence:
            self._obs.pop()

    @property
    def newest_stamp(self) -> float | None:
        """Stamp of the newest observation held (``None`` when empty)."""
        return self._obs[0].stamp if self._obs else None

    def observations(self, now: float | None = None) -> list[Observation]:
        if now is not None:
            self.purge(now)
        return list(self._obs)

    def is_current(self, now: float | None) -> bool:
        rate = self.params.expected_update_rate
        if rate == 0.0 or now is None:
            return True
        return self.last_updated is not None and now - self.last_updated <= rate

    def reset_last_updated(self, now: float | None) -> None:
        """Nav2 ``resetLastUpdated``: after a reset the source counts as fresh."""
        if now is not None:
            self.last_updated = now

    def clear(self) -> None:
        self._obs.clear()

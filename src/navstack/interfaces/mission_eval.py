"""Ground truth and timing measurements of a mission run in the simulator.

The mission itself never sees the simulated world; these watchers do, from outside:

* :class:`CoverageTracker` -- the fraction of the *reachable free space* (the world's
  free cells the robot can observe, :func:`~navstack.exploration.ideal.reachable_free_space`)
  that is known in each published ``/map`` (or global costmap, when exploring without
  SLAM), over time: time to 90 % / 95 %, the final completeness;
* :class:`SlamLatency` -- for every scan SLAM turned into a node, the time until a ``/map``
  containing it was published (simulated time) plus the measured wall time that update
  took to compute (a robot computes the map in real time; a simulated run does not wait
  for it); beside it, the wall time of building the run's final, largest map from every
  node (an update after a loop closure re-renders all of it) added to the simulated p95:
  a bound that charges every update a full rebuild;
* :class:`CommandResponse` -- goal-to-first-motion: for each NavigateToPose goal that
  arrives while the robot stands still, the time until the first non-zero command reaches
  the base (``/cmd_vel``), in simulated and wall-clock time; a goal that ends before any
  motion (already reached, preempted, rejected) is not a response and is left out;
* :class:`PoseError` -- the localization estimate (TF ``map -> base_link``) against the
  true pose every second: RMS and max position error (with SLAM: its trajectory error,
  unaligned -- the map starts at the spawn pose, so it is the world frame);
* :func:`spin_in_place_max` -- the longest stretch of turning in place in a trajectory.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import TransformError
from navstack.core.msgs import OccupancyGrid, Twist
from navstack.exploration.ideal import reachable_free_space
from navstack.interfaces.stack import NavStack
from navstack.runtime.actions import GoalHandle
from navstack.runtime.bus import LATCHED, QoS

FloatArray = NDArray[np.float64]

__all__ = ["CommandResponse", "CoverageTracker", "SlamLatency", "percentile",
           "spin_in_place_max"]


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else math.nan


def robot_half_width(stack: NavStack) -> float:
    """Half the body's narrower side: the clearance the robot needs to pass."""
    poly = np.asarray(stack.body_footprint.polygon)
    return float(min(np.ptp(poly[:, 0]), np.ptp(poly[:, 1])) / 2.0)


@dataclass
class CoverageTracker:
    """Observed fraction of the reachable free space in every ``/map`` (module doc)."""

    stack: NavStack
    sensor_range: float
    topic: str = "/map"
    """``/map`` (SLAM), or a costmap topic when exploring without SLAM."""
    times: list[float] = field(default_factory=list)
    fractions: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        w = self.stack.world
        sp = self.stack.description.spawn
        self.region = reachable_free_space(w.occupied, w.resolution, w.origin_x, w.origin_y,
                                           (sp.x, sp.y), robot_half_width(self.stack),
                                           self.sensor_range)
        rows, cols = np.nonzero(self.region)
        self.xy = np.column_stack((w.origin_x + (cols + 0.5) * w.resolution,
                                   w.origin_y + (rows + 0.5) * w.resolution))
        self.last: OccupancyGrid | None = None
        self._cells: tuple[tuple[float, float, float, int, int], NDArray[np.int64]] | None \
            = None
        qos = LATCHED if self.topic == "/map" else QoS(depth=1)
        self._sub = self.stack.runtime.bus.subscribe(self.topic, OccupancyGrid, self._on_map,
                                                     qos)

    def known_fraction(self, grid: OccupancyGrid) -> float:
        info = grid.info
        data = np.asarray(grid.data).reshape(info.height, info.width)
        key = (info.origin.position.x, info.origin.position.y, info.resolution,
               info.width, info.height)
        if self._cells is None or self._cells[0] != key:  # the map's geometry changed
            cols = np.floor((self.xy[:, 0] - key[0]) / info.resolution).astype(np.int64)
            rows = np.floor((self.xy[:, 1] - key[1]) / info.resolution).astype(np.int64)
            ok = (rows >= 0) & (rows < info.height) & (cols >= 0) & (cols < info.width)
            self._cells = (key, rows[ok] * info.width + cols[ok])
        if len(self.xy) == 0:
            return 0.0
        return float(np.count_nonzero(data.ravel()[self._cells[1]] >= 0)) / len(self.xy)

    def _on_map(self, grid: OccupancyGrid) -> None:
        self.last = grid
        self.times.append(self.stack.now)
        self.fractions.append(self.known_fraction(grid))

    def time_to(self, fraction: float, start: float = 0.0) -> float:
        for t, f in zip(self.times, self.fractions, strict=True):
            if f >= fraction:
                return t - start
        return math.inf

    @property
    def final(self) -> float:
        return self.fractions[-1] if self.fractions else 0.0

    def close(self) -> None:
        self._sub.unsubscribe()


@dataclass
class SlamLatency:
    """Scan-to-``/map`` latency of the SLAM node's map updates (module docstring)."""

    stack: NavStack
    publishes: list[tuple[float, int, float]] = field(default_factory=list)
    """(simulated time, nodes in the map, wall time the update took [s])."""

    def __post_init__(self) -> None:
        self._sub = self.stack.runtime.bus.subscribe("/map", OccupancyGrid, self._on_map,
                                                     LATCHED)

    def _on_map(self, _: OccupancyGrid) -> None:
        slam = self.stack.slam
        if slam is not None and slam.mapper is not None:
            self.publishes.append((self.stack.now, len(slam.mapper.nodes), slam.map_compute_s))

    def latencies(self, compute: bool = False) -> list[float]:
        """Per node: first publication holding it minus the scan's stamp [s, simulated],
        plus (``compute``) the wall time that publication took to compute."""
        slam = self.stack.slam
        if slam is None or slam.mapper is None:
            return []
        out = []
        k = 0
        for node in slam.mapper.nodes:
            while k < len(self.publishes) and self.publishes[k][1] <= node.node_id:
                k += 1
            if k == len(self.publishes):
                break
            t, _, wall = self.publishes[k]
            out.append(t - node.stamp + (wall if compute else 0.0))
        return out

    def build_time(self) -> float:
        """Wall time [s] of building the run's final (largest) map once."""
        slam = self.stack.slam
        if slam is None or slam.mapper is None or not slam.mapper.nodes:
            return 0.0
        t0 = time.perf_counter()  # from every node, as without build_map's reuse
        slam.mapper.build_map(incremental=False).to_occupancy_grid(crop=True)
        return time.perf_counter() - t0

    def summary(self) -> dict[str, float]:
        lat = self.latencies()
        p95 = percentile(lat, 95)
        build = self.build_time()
        return {"slam_map_latency_sim_p95_s": p95, "slam_map_build_s": build,
                "slam_map_latency_p95_s": percentile(self.latencies(compute=True), 95),
                "slam_map_latency_bound_p95_s": p95 + build,
                "slam_map_compute_p95_s": percentile([w for _, _, w in self.publishes], 95),
                "slam_map_updates": len(self.publishes),
                "slam_nodes": len(lat),
                "slam_scans_failed": self.stack.slam.scans_failed if self.stack.slam else 0}

    def close(self) -> None:
        self._sub.unsubscribe()


@dataclass
class CommandResponse:
    """Goal-to-first-motion of NavigateToPose goals sent to a standing robot."""

    stack: NavStack
    moving_threshold: float = 0.01
    delays: list[float] = field(default_factory=list)
    wall_delays: list[float] = field(default_factory=list)
    starts: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._last_motion = -math.inf
        self._pending: tuple[float, float, GoalHandle[Any]] | None = None
        bus = self.stack.runtime.bus
        self._sub = bus.subscribe("/cmd_vel", Twist, self._on_cmd, QoS(depth=10))
        server = bus.action_servers.get("/navigate_to_pose")
        self._server: Any = server
        self._orig = server.on_goal if server is not None else None
        if server is not None:
            server.on_goal = self._on_goal

    def _moving(self, cmd: Twist) -> bool:
        return abs(cmd.linear.x) > self.moving_threshold or abs(cmd.angular.z) > 0.05

    def _on_goal(self, handle: GoalHandle[Any]) -> bool | str:
        assert self._orig is not None
        verdict: bool | str = self._orig(handle)
        standing = self.stack.now - self._last_motion > 0.5
        if verdict is True and standing and self._pending is None:
            self._pending = (self.stack.now, time.perf_counter(), handle)
            handle.add_done_callback(lambda _: self._ended(handle))
        return verdict

    def _ended(self, handle: GoalHandle[Any]) -> None:
        if self._pending is not None and self._pending[2] is handle:
            self._pending = None  # ended without moving the robot: not a response

    def _on_cmd(self, cmd: Twist) -> None:
        if not self._moving(cmd):
            return
        self._last_motion = self.stack.now
        if self._pending is not None:
            t0, w0, _ = self._pending
            self.delays.append(self.stack.now - t0)
            self.wall_delays.append(time.perf_counter() - w0)
            self.starts.append(t0)
            self._pending = None

    def summary(self) -> dict[str, Any]:
        slowest = sorted(zip(self.delays, self.starts, strict=True), reverse=True)[:5]
        return {"goal_to_first_motion_p95_s": percentile(self.delays, 95),
                "goal_to_first_motion_wall_p95_s": percentile(self.wall_delays, 95),
                "goal_to_first_motion_samples": len(self.delays),
                "goal_to_first_motion_s": [round(d, 3) for d in self.delays],
                "goal_to_first_motion_slowest": [[round(t, 2), round(d, 3)]
                                                 for d, t in slowest]}

    def close(self) -> None:
        self._sub.unsubscribe()
        if self._server is not None and self._orig is not None:
            self._server.on_goal = self._orig


@dataclass
class PoseError:
    """Estimated vs true robot position, sampled every ``period`` (module docstring)."""

    stack: NavStack
    period: float = 1.0
    samples: list[tuple[float, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.stack.runtime.scheduler.create_timer(self.period, self._sample)

    def _sample(self) -> None:
        try:
            est = self.stack.runtime.tf.lookup_pose2d("map", "base_link")
        except TransformError:
            return
        self.stack.sim.advance()
        true = self.stack.sim.sim.pose
        self.samples.append((self.stack.now, math.hypot(est.x - true.x, est.y - true.y)))

    def summary(self) -> dict[str, Any]:
        if not self.samples:
            return {}
        err = np.array([e for _, e in self.samples])
        k = int(np.argmax(err))
        return {"pose_error_rms_m": float(np.sqrt(np.mean(err ** 2))),
                "pose_error_max_m": float(err[k]), "pose_error_max_at_s": self.samples[k][0],
                "pose_error_trace": [[round(t, 1), round(e, 3)] for t, e in self.samples[::5]]}


def spin_in_place_max(traj: FloatArray, radius: float = 0.15, min_turn: float = 0.5) -> float:
    """Longest time [s] the robot stayed within ``radius`` of a point while turning by at
    least ``min_turn`` rad in that time (``traj`` rows: t, x, y, theta)."""
    if len(traj) < 2:
        return 0.0
    t, x, y = traj[:, 0], traj[:, 1], traj[:, 2]
    heading = np.unwrap(traj[:, 3])
    best = 0.0
    j = 0
    n = len(traj)
    for i in range(n):
        j = max(j, i)
        while j + 1 < n and math.hypot(x[j + 1] - x[i], y[j + 1] - y[i]) <= radius:
            j += 1
        turned = float(np.ptp(heading[i:j + 1]))
        if turned >= min_turn:
            best = max(best, float(t[j] - t[i]))
    return best

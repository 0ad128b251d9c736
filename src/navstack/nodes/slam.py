"""``SlamNode``: online SLAM in the runtime, the job of slam_toolbox's sync/async nodes.

* subscribes ``scan_topic``; the odometry pose at each scan's stamp comes from TF
  (``odom_frame -> base_frame``), the laser mount from ``base_frame -> scan frame``; a
  scan waits up to ``transform_timeout`` for them in a
  :class:`~navstack.runtime.tf_filter.TfMessageFilter` of ``scan_queue_size``;
* publishes ``map_frame -> odom_frame`` every ``transform_publish_period`` (stamped
  ``transform_timeout`` ahead, as slam_toolbox does, so lookups at the newest odometry time
  never wait for it) and the occupancy grid on ``/map`` (latched) every
  ``map_update_interval``;
* services ``/slam_toolbox/save_map`` (``{"name": path}`` -> YAML + PGM),
  ``/slam_toolbox/serialize_map`` (``{"filename": path}``) and
  ``/slam_toolbox/deserialize_pose_graph`` (``{"filename": path, "match_type":
  "continue" | "localize", "initial_pose": [x, y, yaw] | None}``).

``synchronous: true`` (slam_toolbox's sync node) processes every accepted scan in the scan
callback, so a simulated run is deterministic.  ``synchronous: false`` (the async node)
hands the newest scan to a worker thread and drops scans that arrive while it is busy;
results reach ``map -> odom`` on the next publish tick.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from navstack.core.msgs import (
    Header,
    LaserScan,
    MapMetaData,
    OccupancyGrid,
    Point,
    Pose,
    Quaternion,
    TFMessage,
    Transform,
    TransformStamped,
)
from navstack.core.msgs import Pose2D as Pose2DMsg
from navstack.mapping.slam import LaserGeometry, SlamMapper
from navstack.mapping.slam_io import load_posegraph, save_posegraph
from navstack.mapping.slam_params import SlamParams
from navstack.runtime.bus import SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime
from navstack.runtime.tf_filter import TfMessageFilter

__all__ = ["SlamNode", "pad_to_extent"]


def unknown_canvas(extent: list[float], resolution: float, frame_id: str,
                   stamp: float) -> OccupancyGrid:
    """An all-unknown map covering ``[xmin, ymin, xmax, ymax]`` (the costmaps take its
    size before SLAM has seen anything)."""
    xmin, ymin, xmax, ymax = (float(v) for v in extent)
    width = max(1, math.ceil((xmax - xmin) / resolution - 1e-9))
    height = max(1, math.ceil((ymax - ymin) / resolution - 1e-9))
    info = MapMetaData(stamp, resolution, width, height,
                       Pose(Point(xmin, ymin, 0.0), Quaternion.from_yaw(0.0)))
    return OccupancyGrid(Header(stamp, frame_id), info,
                         np.full((height, width), -1, dtype=np.int8))


def pad_to_extent(grid: OccupancyGrid, extent: list[float]) -> OccupancyGrid:
    """``grid`` grown with unknown cells (-1) to cover ``[xmin, ymin, xmax, ymax]``.

    The planner refuses goals outside the costmap, and the global costmap takes the size
    of ``/map``; a SLAM map only covers what has been seen, so navigating towards a goal
    in unexplored space needs a canvas (``map_minimum_extent``).  Cells stay aligned."""
    info = grid.info
    res = info.resolution
    ox, oy = info.origin.position.x, info.origin.position.y
    xmin, ymin, xmax, ymax = (float(v) for v in extent)
    left = max(0, math.ceil((ox - xmin) / res - 1e-9))
    below = max(0, math.ceil((oy - ymin) / res - 1e-9))
    right = max(0, math.ceil((xmax - (ox + info.width * res)) / res - 1e-9))
    above = max(0, math.ceil((ymax - (oy + info.height * res)) / res - 1e-9))
    if left == below == right == above == 0:
        return grid
    data = np.pad(np.asarray(grid.data).reshape(info.height, info.width),
                  ((below, above), (left, right)), constant_values=-1).astype(np.int8)
    origin = replace(info.origin, position=replace(info.origin.position, x=ox - left * res,
                                                   y=oy - below * res))
    new_info = replace(info, width=data.shape[1], height=data.shape[0], origin=origin)
    return replace(grid, info=new_info, data=data)


class SlamNode(Node):
    """Runs a :class:`SlamMapper` on ``/scan`` + TF odometry; publishes ``map -> odom``."""

    def __init__(self, runtime: Runtime, params: SlamParams | None = None,
                 name: str = "slam_toolbox") -> None:
        super().__init__(name, runtime)
        self.params = params or SlamParams()
        self.mapper: SlamMapper | None = None
        self.scans_dropped = 0
        self.scans_failed = 0
        """Scans the mapper raised on: counted, logged, skipped (mapping goes on)."""
        self.last_problem = ""
        self.maps_published = 0
        self.map_compute_s = 0.0
        """Wall time [s] the last ``/map`` update took to compute."""
        self._pending: tuple[np.ndarray, np.ndarray, float] | None = None
        self._worker: threading.Thread | None = None
        self._lock = threading.Lock()
        self._loaded: SlamMapper | None = None
        self._mapped = False  # the first map with a scan in it was published
        self._scans: TfMessageFilter[LaserScan, tuple[Pose2DMsg, Pose2DMsg]] = TfMessageFilter(
            self, self._scan_transforms, self._on_scan_placed,
            queue_size=self.params.scan_queue_size, timeout=self.params.transform_timeout,
            what="scan", on_drop=self._on_scan_dropped)

    # --- lifecycle -----------------------------------------------------------------------
    def on_configure(self) -> None:
        p = self.params
        self.pub_tf = self.create_publisher("/tf", TFMessage, QoS(depth=100))
        self.pub_map = self.create_latched_publisher("/map", OccupancyGrid)
        self.create_subscription(p.scan_topic, LaserScan, self._on_scan, SENSOR_DATA)
        if p.transform_publish_period > 0:
            self.create_timer(p.transform_publish_period, self._publish_transform)
        self.create_timer(p.map_update_interval, self.publish_map)
        prefix = f"/{self.name}"
        self.bus.advertise_service(f"{prefix}/save_map", self._save_map_request)
        self.bus.advertise_service(f"{prefix}/serialize_map", self._serialize_request)
        self.bus.advertise_service(f"{prefix}/deserialize_pose_graph",
                                   self._deserialize_request)

    def on_activate(self) -> None:
        if self.params.map_minimum_extent is not None and self.maps_published == 0:
            self.publish_map()  # the canvas: costmaps know the map's size from the start
        # map -> odom from now on: the periodic messages are stamped transform_timeout
        # ahead, which would leave the first lookups (the first plan) before the edge
        self._publish_transform(ahead=False)
        self._publish_transform()

    def on_cleanup(self) -> None:
        prefix = f"/{self.name}"
        for service in ("save_map", "serialize_map", "deserialize_pose_graph"):
            self.bus.remove_service(f"{prefix}/{service}")
        self._scans.clear()

    # --- scans ---------------------------------------------------------------------------
    @property
    def tf_failures(self) -> int:
        """Scans dropped because TF had no odometry at their stamp within
        ``transform_timeout``."""
        return self._scans.dropped_timeout

    def _on_scan(self, scan: LaserScan) -> None:
        """Queue the scan until TF has odometry at its stamp (a tf2 message filter): the
        odometry of the same instant may arrive just after the scan."""
        self._scans.add(scan)

    def _scan_transforms(self, scan: LaserScan) -> tuple[Pose2DMsg, Pose2DMsg]:
        p = self.params
        odom = self.tf.lookup_pose2d(p.odom_frame, p.base_frame, scan.header.stamp)
        mount = self.tf.lookup_pose2d(p.base_frame, scan.header.frame_id or p.base_frame)
        return odom, mount

    def _on_scan_placed(self, scan: LaserScan, transforms: tuple[Pose2DMsg, Pose2DMsg]) -> None:
        self._process(scan, *transforms)

    def _on_scan_dropped(self, scan: LaserScan, reason: str) -> None:
        self.last_problem = reason

    def _process(self, scan: LaserScan, odom: Pose2DMsg, mount: Pose2DMsg) -> None:
        p = self.params
        stamp = scan.header.stamp
        if self.mapper is None:
            self.mapper = self._loaded or SlamMapper(p, LaserGeometry.uniform(
                scan.angle_min, scan.angle_increment, len(scan.ranges), scan.range_min,
                scan.range_max, (mount.x, mount.y, mount.theta)))
        odom_arr = np.array([odom.x, odom.y, odom.theta])
        ranges = np.asarray(scan.ranges, np.float32)
        if p.synchronous:
            if self._map_scan(ranges, odom_arr, stamp) and not self._mapped:
                self._mapped = True
                self.publish_map()  # navigation needs a first map right away
            return
        with self._lock:
            if self._worker is not None and self._worker.is_alive():
                self.scans_dropped += 1  # async: the mapper is busy, keep only new scans
                return
            self._worker = threading.Thread(target=self._process_async,
                                            args=(ranges, odom_arr, stamp), daemon=True)
            self._worker.start()

    def _process_async(self, ranges: np.ndarray, odom: np.ndarray, stamp: float) -> None:
        self._map_scan(ranges, odom, stamp)

    def _map_scan(self, ranges: np.ndarray, odom: np.ndarray, stamp: float) -> bool:
        """Give one scan to the mapper; True when it became a node.  An exception inside
        the mapper (a bug met on input nobody foresaw) loses that scan, not the session:
        it is counted in ``scans_failed``, named in ``last_problem`` and logged with its
        traceback, and the next scan is mapped as usual -- the navigation and the mission
        above keep running on the map built so far."""
        assert self.mapper is not None
        try:
            return self.mapper.process_scan(ranges, odom, stamp)
        except Exception as exc:  # any mapper bug: keep the session alive
            self.scans_failed += 1
            self.last_problem = (f"scan at t={stamp:.3f} not mapped: "
                                 f"{type(exc).__name__}: {exc}")
            self.log.exception(f"{self.last_problem} ({self.scans_failed} so far)")
            return False

    def wait_idle(self, timeout: float = 10.0) -> None:
        """Block until the async worker has finished its scan (tests, shutdown)."""
        worker = self._worker
        if worker is not None:
            worker.join(timeout)

    # --- outputs -------------------------------------------------------------------------
    @property
    def map_to_odom(self) -> np.ndarray:
        """``map -> odom``; before the first scan, ``map_start_pose`` (the odometry
        starts at its origin), so that the robot is where navigation expects it."""
        if self.mapper is not None:
            return self.mapper.map_to_odom
        start = self.params.map_start_pose
        return np.zeros(3) if start is None else np.asarray(start[:3], dtype=float)

    def _publish_transform(self, ahead: bool = True) -> None:
        self._scans.drain()
        p = self.params
        m2o = self.map_to_odom
        transform = Transform.from_pose2d(Pose2DMsg(float(m2o[0]), float(m2o[1]),
                                                    float(m2o[2])))
        stamp = self.now + (p.transform_timeout if ahead else 0.0)
        self.pub_tf.publish(TFMessage((TransformStamped(Header(stamp, p.map_frame),
                                                        p.odom_frame, transform),)))

    def occupancy_grid(self) -> OccupancyGrid | None:
        """The current map as an OccupancyGrid; before the first scan an unknown canvas
        of ``map_minimum_extent`` (``None`` without one)."""
        extent = self.params.map_minimum_extent
        if self.mapper is None or not self.mapper.nodes:
            return None if extent is None else unknown_canvas(
                extent, self.params.resolution, self.params.map_frame, self.now)
        with self._lock:
            # the node scans only: clearing with the latest scans on top eroded walls the
            # planner then routed through (docs/mapping.md, "Online")
            grid = self.mapper.live_map()
        msg = grid.to_occupancy_grid(self.params.map_frame, self.now, crop=True,
                                     free_thresh=self.params.map_free_thresh)
        return msg if extent is None else pad_to_extent(msg, extent)

    def saved_map(self) -> OccupancyGrid | None:
        """The map as ``save_map`` writes it: every node scan rendered at its current pose
        (the published live map re-renders only after a loop closure moves the graph by
        half a cell, so it differs from this in a few cells)."""
        if self.mapper is None or not self.mapper.nodes:
            return None
        with self._lock:
            grid = self.mapper.build_map()
        return grid.to_occupancy_grid(self.params.map_frame, self.now, crop=True,
                                      free_thresh=self.params.map_free_thresh)

    def publish_map(self) -> None:
        t0 = time.perf_counter()
        grid = self.occupancy_grid()
        # wall time of this update: in a simulated run, the delay a robot's computer adds
        # to the timer's (the exploration bench's map latency)
        self.map_compute_s = time.perf_counter() - t0
        if grid is not None:
            self.pub_map.publish(grid)
            self.maps_published += 1

    # --- services --------------------------------------------------------------------------
    def _save_map_request(self, request: dict[str, Any]) -> dict[str, Any]:
        name = str(request.get("name", "map"))
        if self.mapper is None or not self.mapper.nodes:
            return {"result": False, "reason": "no map yet: SLAM has not processed a scan"}
        path = self.mapper.build_map().save(Path(name).with_suffix(".yaml"),
                                            free_thresh=self.params.map_free_thresh)
        return {"result": True, "path": str(path)}

    def _serialize_request(self, request: dict[str, Any]) -> dict[str, Any]:
        if self.mapper is None or not self.mapper.nodes:
            return {"result": False, "reason": "no pose graph yet: SLAM has not processed a scan"}
        self.wait_idle()
        path = save_posegraph(self.mapper, str(request.get("filename", "map")))
        return {"result": True, "path": str(path)}

    def _deserialize_request(self, request: dict[str, Any]) -> dict[str, Any]:
        match_type = str(request.get("match_type", "continue"))
        if match_type not in ("continue", "localize"):
            return {"result": False, "reason": f"match_type {match_type!r}: use 'continue' "
                                               "or 'localize'"}
        initial = request.get("initial_pose")
        start = None if initial is None else np.asarray(initial, float)
        if start is not None and (start.shape != (3,) or not np.isfinite(start).all()):
            return {"result": False, "reason": f"initial_pose {initial!r}: give [x, y, yaw]"}
        mode = "localization" if match_type == "localize" else "mapping"
        self.wait_idle()
        mapper = load_posegraph(str(request["filename"]),
                                self.params.updated(mode=mode), start_pose=start)
        self.mapper = mapper
        self._loaded = mapper
        self._publish_transform()
        return {"result": True, "nodes": len(mapper.nodes)}

    def load(self, filename: str | Path, match_type: str = "continue",
             initial_pose: tuple[float, float, float] | None = None) -> None:
        """Deserialize a saved pose graph (see the service)."""
        reply = self._deserialize_request({"filename": str(filename), "match_type": match_type,
                                           "initial_pose": initial_pose})
        if not reply["result"]:
            raise ValueError(reply["reason"])

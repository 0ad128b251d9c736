"""Offline SLAM on a recorded bag: ``run_bag``, the bag twin of ``mapping.offline.run_carmen``.

Feeds every ``/scan`` with the ``/odom`` pose at the scan's stamp (linear interpolation of
x, y and unwrapped yaw between the two odometry messages around it) to a
:class:`~navstack.mapping.slam.SlamMapper`, then runs the batch optimisation.  The laser
geometry is the first scan's; its mounting on the robot comes from ``/tf_static``
(scan frame -> the odometry's ``child_frame_id``).  Unlike the subsampled CARMEN
benchmark logs, a bag holds every scan, so slam_toolbox's own gates apply
(``minimum_travel_distance`` 0.5 m, ``minimum_travel_heading`` 0.5 rad,
``minimum_time_interval`` 0.5 s, overridable).  When the bag has ``/ground_truth``
(the simulator's true pose) the graph nodes are scored against it with the relative
pose error of Kümmerle et al. (2009) over consecutive nodes.  Output files are those of
``navstack slam`` (:func:`navstack.mapping.offline.write_outputs`).
"""

from __future__ import annotations

import json
import math
import statistics
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import NavstackError
from navstack.core.msgs import LaserScan, Odometry, TFMessage
from navstack.core.tf import TransformTree
from navstack.mapping.map_metrics import relative_pose_error
from navstack.mapping.offline import (
    OfflineResult,
    OfflineSlamError,
    log_duration,
    write_outputs,
)
from navstack.mapping.slam import LaserGeometry, SlamMapper
from navstack.mapping.slam_params import SlamParams
from navstack.runtime.recording.reader import BagReader

FloatArray = NDArray[np.float64]
GATES = ("minimum_travel_distance", "minimum_travel_heading", "minimum_time_interval")


def _poses(msgs: list[Odometry]) -> tuple[FloatArray, FloatArray]:
    """Stamps ``(N,)`` and unwrapped ``(N, 3)`` poses of odometry messages, time-sorted."""
    arr = np.array([(m.header.stamp, m.pose.pose.position.x, m.pose.pose.position.y,
                     m.pose.pose.orientation.yaw) for m in msgs], dtype=np.float64)
    arr = arr[np.argsort(arr[:, 0], kind="stable")]
    arr[:, 3] = np.unwrap(arr[:, 3])
    return arr[:, 0], arr[:, 1:]


def _at(t: FloatArray, poses: FloatArray, at: FloatArray) -> FloatArray:
    out = np.column_stack([np.interp(at, t, poses[:, k]) for k in range(3)])
    out[:, 2] = np.arctan2(np.sin(out[:, 2]), np.cos(out[:, 2]))
    return out


def _read(bag_path: Path, scan_topic: str, odom_topic: str, truth_topic: str
          ) -> tuple[list[LaserScan], list[Odometry], list[Odometry], TransformTree]:
    with BagReader(bag_path) as bag:
        info = bag.topics()
        for topic, kind in ((scan_topic, "sensor_msgs/msg/LaserScan"),
                            (odom_topic, "nav_msgs/msg/Odometry")):
            if topic not in info:
                raise OfflineSlamError(f"{bag_path}: no {topic} topic ({kind}) in the bag; "
                                       f"SLAM needs scans and odometry (topics: "
                                       f"{', '.join(info) or 'none'})")
        topics = [scan_topic, odom_topic, *(t for t in (truth_topic, "/tf_static")
                                            if t in info)]
        scans: list[LaserScan] = []
        odom: list[Odometry] = []
        truth: list[Odometry] = []
        tree = TransformTree(cache_time=1e9)
        for item in bag.messages(topics):
            msg = item.msg
            if item.topic == scan_topic and isinstance(msg, LaserScan):
                scans.append(msg)
            elif item.topic == odom_topic and isinstance(msg, Odometry):
                odom.append(msg)
            elif item.topic == truth_topic and isinstance(msg, Odometry):
                truth.append(msg)
            elif isinstance(msg, TFMessage):
                tree.apply_tf_message(msg, True)
    return scans, odom, truth, tree


def run_bag(bag_path: str | Path, params_overrides: Mapping[str, Any] | None = None, *,
            scan_topic: str = "/scan", odom_topic: str = "/odom",
            truth_topic: str = "/ground_truth", max_scans: int | None = None,
            params_file: str = "") -> OfflineResult:
    """SLAM over a bag's scans and odometry (module docstring); errors name the bag."""
    path = Path(bag_path)
    params = SlamParams.from_mapping(params_overrides, file=params_file,
                                     key_path="slam_toolbox.ros__parameters" if params_file
                                     else "")
    if params.mode != "mapping":
        raise OfflineSlamError(f"slam_toolbox mode '{params.mode}' cannot build a map from "
                               f"a bag; use mode: mapping")
    scans, odom, truth, tree = _read(path, scan_topic, odom_topic, truth_topic)
    if not scans or len(odom) < 2:
        raise OfflineSlamError(f"{path}: {len(scans)} scans and {len(odom)} odometry "
                               f"messages; SLAM needs scans and at least two odometry poses")
    first = scans[0]
    base = odom[0].child_frame_id or "base_link"
    mount = [0.0, 0.0, 0.0]
    if first.header.frame_id and first.header.frame_id != base:
        try:
            m = tree.lookup_pose2d(base, first.header.frame_id)
            mount = [m.x, m.y, m.theta]
        except NavstackError as exc:
            raise OfflineSlamError(f"{path}: no static transform {base} -> "
                                   f"{first.header.frame_id} in /tf_static ({exc})") from None
    odom_t, odom_poses = _poses(odom)
    usable = [s for s in scans if s.ranges.size == first.ranges.size
              and s.angle_min == first.angle_min and s.angle_increment == first.angle_increment
              and odom_t[0] <= s.header.stamp <= odom_t[-1]]
    if max_scans is not None:
        usable = usable[:max_scans]
    if not usable:
        raise OfflineSlamError(f"{path}: no scan lies within the odometry's time span "
                               f"[{odom_t[0]:.3f}, {odom_t[-1]:.3f}] s")
    stamps = np.array([s.header.stamp for s in usable])
    odometry = _at(odom_t, odom_poses, stamps)
    laser = LaserGeometry.uniform(first.angle_min, first.angle_increment, first.ranges.size,
                                  first.range_min, first.range_max, mount)
    mapper = SlamMapper(params, laser)
    node_index = np.empty(len(usable), dtype=np.int64)
    made: list[int] = []
    times: list[float] = []
    wall = 0.0
    for k, scan in enumerate(usable):
        t0 = time.perf_counter()
        if mapper.process_scan(scan.ranges, odometry[k], float(stamps[k])):
            made.append(k)
            times.append(time.perf_counter() - t0)
        wall += time.perf_counter() - t0
        node_index[k] = len(mapper.nodes) - 1
    t0 = time.perf_counter()
    mapper.finalize()
    wall += time.perf_counter() - t0
    trajectory = mapper.trajectory(odometry, node_index)
    reference = rpe = odo_rpe = None
    if len(truth) >= 2:
        truth_t, truth_poses = _poses(truth)
        reference = _at(truth_t, truth_poses, stamps)
        if len(made) >= 2:
            pairs = np.column_stack((made[:-1], made[1:]))
            rpe = relative_pose_error(trajectory, reference, pairs)
            odo_rpe = relative_pose_error(odometry, reference, pairs)
    duration = log_duration(stamps)
    overrides = {g: getattr(params, g) for g in GATES} | dict(params_overrides or {})
    return OfflineResult(
        log_path=path, mapper=mapper, trajectory=trajectory, odometry=odometry,
        reference=reference, stamps=stamps, node_index=node_index, rpe=rpe,
        odometry_rpe=odo_rpe, wall_s=wall,
        ms_per_scan=1e3 * statistics.median(times) if times else math.nan,
        log_duration_s=duration,
        speedup=None if duration is None or wall <= 0.0 else duration / wall,
        scans_in_log=len(scans), overrides=overrides)


def write_bag_outputs(result: OfflineResult, out_dir: str | Path) -> dict[str, str]:
    """:func:`write_outputs`, with the summary saying the reference is the bag's ground
    truth (the CARMEN wording would be wrong here)."""
    files = write_outputs(result, out_dir)
    summary_path = Path(files["summary"])
    summary = json.loads(summary_path.read_text())
    summary["reference"] = ("/ground_truth at the scan stamps (RPE over consecutive graph "
                            "nodes)" if result.reference is not None
                            else "none (the bag has no /ground_truth)")
    summary_path.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return files

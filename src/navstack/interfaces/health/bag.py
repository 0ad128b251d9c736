"""Observations from a recorded run (rosbag2 MCAP/sqlite3 or ROS 1), for ``navstack doctor
--bag``.

A bag holds topics only, so some contracts are inferred rather than read (and the checks
say so): the controller is taken as inactive when a plan was published during a goal and
no ``/cmd_vel`` followed; velocity limits as zero when every command of a planned goal
was zero.  Goals come from ``/navigate_to_pose/_action/status`` (what a Nav2 recording
and :class:`~navstack.runtime.recording.BagRecorder` write); without it the whole bag is
taken as one goal.  Costmaps are judged from ``/global_costmap/costmap`` and
``/local_costmap/costmap`` when recorded (OccupancyGrid values: 100 lethal/inscribed, -1
unknown).  Times are bag log times; odometry uses header stamps.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from navstack.core.errors import FrameConflictError, InvalidMessage, TransformError
from navstack.core.msgs import OccupancyGrid, Odometry, TFMessage, Twist
from navstack.core.msgs import Path as PathMsg
from navstack.core.tf import TransformTree
from navstack.interfaces.health.analysis import pose_stds
from navstack.interfaces.health.model import (
    CostmapSnapshot,
    GoalSpan,
    Observations,
)
from navstack.interfaces.health.monitor import LOCALIZATION_TOPICS
from navstack.runtime.recording.goal_status import STATUS_NAMES, GoalStatusArray
from navstack.runtime.recording.reader import BagReader
from navstack.runtime.recording.recorder import DEFAULT_TOPICS, GOAL_STATUS_TOPIC

COSTMAP_TOPICS = ("/global_costmap/costmap", "/local_costmap/costmap")
HEALTH_TOPICS: tuple[str, ...] = (*DEFAULT_TOPICS, "/cmd_vel_nav", *COSTMAP_TOPICS,
                                  "/odometry/filtered")
"""What to record so that ``navstack doctor --bag`` can judge every contract it can."""

_BLOCKED = 99  # OccupancyGrid value of inscribed (253) and lethal (254) costs


def _goals(statuses: list[tuple[float, GoalStatusArray]]) -> list[GoalSpan]:
    spans: dict[bytes, dict[str, Any]] = {}
    for log_t, arr in statuses:
        for s in arr.status_list:
            rec = spans.setdefault(s.goal_info.goal_id, {"start": s.goal_info.stamp,
                                                         "end": None, "status": "EXECUTING"})
            if s.terminal and rec["end"] is None:
                rec.update(end=log_t, status=STATUS_NAMES.get(s.status, "UNKNOWN"))
    return [GoalSpan(r["start"], r["end"], r["status"])
            for r in sorted(spans.values(), key=lambda r: r["start"])]


def _costmap(name: str, grid: OccupancyGrid, tf: TransformTree, base: str) -> CostmapSnapshot:
    data = np.asarray(grid.data, dtype=np.int16).reshape(grid.info.height, grid.info.width)
    known = data >= 0
    n = int(np.count_nonzero(known))
    frac = float(np.count_nonzero(known & (data >= _BLOCKED))) / n if n else 0.0
    cost: int | None = None
    frame = grid.header.frame_id
    try:
        pose = tf.lookup_pose2d(frame, base, None)
    except TransformError:
        pose = None
    if pose is not None:
        o = grid.info.origin.position
        mx = math.floor((pose.x - o.x) / grid.info.resolution)
        my = math.floor((pose.y - o.y) / grid.info.resolution)
        if 0 <= mx < grid.info.width and 0 <= my < grid.info.height:
            cost = int(data[my, mx])
    return CostmapSnapshot(name.strip("/").split("/")[0], frame, n, frac, cost,
                           cost is not None and cost >= 100)


def observations_from_bag(path: str | Path, global_frame: str = "map",
                          odom_frame: str = "odom", base_frame: str = "base_link"
                          ) -> Observations:
    """Read a bag into :class:`~.model.Observations` (see the module docstring)."""
    times: dict[str, list[float]] = {}
    cmd: list[tuple[float, float, float]] = []
    odom: list[tuple[float, float, float, float, float, float]] = []
    tf_samples: dict[str, list[tuple[float, float]]] = {}
    tf_msgs: list[tuple[TFMessage, bool]] = []
    plans: list[tuple[float, str]] = []
    cov: list[tuple[float, float, float, float]] = []
    cov_topic = ""
    statuses: list[tuple[float, GoalStatusArray]] = []
    grids: dict[str, OccupancyGrid] = {}
    with BagReader(path) as bag:
        present = bag.topics()
        wanted = [t for t in (*HEALTH_TOPICS, GOAL_STATUS_TOPIC)
                  if t in present and present[t].convertible]
        start, end = bag.start_time, bag.end_time
        for m in bag.messages(wanted):
            t, msg = m.log_time, m.msg
            times.setdefault(m.topic, []).append(t)
            if m.topic == "/cmd_vel" and isinstance(msg, Twist):
                cmd.append((t, msg.linear.x, msg.angular.z))
            elif m.topic == "/odom" and isinstance(msg, Odometry):
                p, tw = msg.pose.pose, msg.twist.twist
                odom.append((msg.header.stamp, p.position.x, p.position.y, p.orientation.yaw,
                             tw.linear.x, tw.angular.z))
            elif m.topic in ("/tf", "/tf_static") and isinstance(msg, TFMessage):
                tf_msgs.append((msg, m.topic == "/tf_static"))
                if m.topic == "/tf":
                    for ts in msg.transforms:
                        tf_samples.setdefault(f"{ts.header.frame_id}->{ts.child_frame_id}",
                                              []).append((t, ts.header.stamp))
            elif m.topic == "/plan" and isinstance(msg, PathMsg):
                plans.append((t, msg.header.frame_id))
            elif m.topic in LOCALIZATION_TOPICS and isinstance(msg, LOCALIZATION_TOPICS[m.topic]):
                cov_topic = m.topic
                cov.append((t, *pose_stds(msg.pose.covariance)))
            elif m.topic in COSTMAP_TOPICS and isinstance(msg, OccupancyGrid):
                grids[m.topic] = msg
            elif m.topic == GOAL_STATUS_TOPIC and isinstance(msg, GoalStatusArray):
                statuses.append((t, msg))
    notes: list[str] = []
    tree = TransformTree(cache_time=max(end - start, 0.0) + 10.0)
    for msg, static in tf_msgs:
        try:
            tree.apply_tf_message(msg, static)
        except (InvalidMessage, FrameConflictError) as exc:
            notes.append(f"rejected transform: {exc}")
    goals = _goals(statuses)
    if GOAL_STATUS_TOPIC not in present:
        notes.append(f"no {GOAL_STATUS_TOPIC} in the bag: the whole bag is taken as one goal")
        goals = [GoalSpan(start, None, "UNKNOWN")]
    missing = [t for t in ("/cmd_vel", "/odom", "/tf", *COSTMAP_TOPICS) if t not in present]
    if missing:
        notes.append(f"not recorded: {', '.join(missing)} (record {', '.join(HEALTH_TOPICS)})")
    sensors: tuple[str, ...] = ()
    if base_frame in tree:
        sensors = tuple(f for f in tree.frames()
                        if f != base_frame and tree.parent_of(f) == base_frame)
    return Observations(
        source=f"bag {path}", start=start, now=end,
        topic_times={k: np.asarray(v, dtype=np.float64) for k, v in times.items()},
        cmd=np.asarray(cmd, dtype=np.float64).reshape(-1, 3),
        odom=np.asarray(sorted(odom), dtype=np.float64).reshape(-1, 6),
        tf=tree, tf_samples={k: np.asarray(v, dtype=np.float64).reshape(-1, 2)
                             for k, v in tf_samples.items()},
        global_frame=global_frame, odom_frame=odom_frame, base_frame=base_frame,
        sensor_frames=sensors, goals=goals, plans=plans,
        costmaps=[_costmap(t, g, tree, base_frame) for t, g in sorted(grids.items())],
        covariance=np.asarray(cov, dtype=np.float64).reshape(-1, 4), covariance_topic=cov_topic,
        notes=notes)

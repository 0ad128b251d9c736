"""Load what ``navstack report`` needs from a bag into arrays (one pass over the bag).

*Trajectory source.*  ``/ground_truth`` (the simulator's true pose, ``map`` frame) when
the bag has it -- that is what the demo scores -- otherwise ``/odom`` (wheel odometry,
``odom`` frame, drifts).  Pose times are header stamps; speeds come from the
message's body-frame twist.
*Goals.*  ``/navigate_to_pose/_action/status`` gives each goal's acceptance time
(``goal_info.stamp``) and the log time of its terminal status; ``/goal_pose`` gives its
position (the goal pose logged at its acceptance time, else the n-th goal pose).
*Scans.*  The laser's yaw on the robot comes from ``/tf_static`` (scan frame -> the
trajectory's ``child_frame_id``); without it the laser is taken to face forward.
*Clearance inputs.*  ``/sim/footprint`` (the body's outline, a LINE_STRIP Marker in the
robot frame) and ``/sim/obstacles`` (walkers, a MarkerArray) when the simulator recorded
them (:class:`~navstack.sim.node.SimulatorNode`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path as FsPath

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import NavstackError
from navstack.core.msgs import (
    LaserScan,
    Marker,
    MarkerArray,
    OccupancyGrid,
    Odometry,
    Path,
    PoseStamped,
    TFMessage,
)
from navstack.core.msgs import Twist as TwistMsg
from navstack.core.tf import TransformTree
from navstack.interfaces.report_metrics import forward_free_distance, obstacle_shapes
from navstack.runtime.recording.goal_status import STATUS_NAMES, GoalStatusArray
from navstack.runtime.recording.reader import BagReader
from navstack.runtime.recording.recorder import GOAL_POSE_TOPIC, GOAL_STATUS_TOPIC

FloatArray = NDArray[np.float64]

TRAJECTORY_TOPICS = ("/ground_truth", "/odom")
EXPECTED: dict[str, str] = {
    "/ground_truth": "nav_msgs/msg/Odometry", "/odom": "nav_msgs/msg/Odometry",
    "/cmd_vel": "geometry_msgs/msg/Twist", "/scan": "sensor_msgs/msg/LaserScan",
    "/map": "nav_msgs/msg/OccupancyGrid", "/plan": "nav_msgs/msg/Path",
    GOAL_POSE_TOPIC: "geometry_msgs/msg/PoseStamped",
    GOAL_STATUS_TOPIC: "action_msgs/msg/GoalStatusArray", "/tf_static": "tf2_msgs/msg/TFMessage",
    "/sim/footprint": "visualization_msgs/msg/Marker",
    "/sim/obstacles": "visualization_msgs/msg/MarkerArray",
}


@dataclass
class Trajectory:
    """Poses and body velocities of one odometry-type topic (``t`` header stamps [s])."""

    topic: str
    frame: str
    child_frame: str
    t: FloatArray
    xy: FloatArray
    yaw: FloatArray
    speed: FloatArray
    wz: FloatArray


@dataclass
class GoalEvent:
    """One navigation goal: acceptance, end (``None`` if it never ended), outcome."""

    index: int
    start: float
    end: float | None
    status: str
    xy: tuple[float, float] | None


@dataclass
class BagData:
    path: FsPath
    start: float
    end: float
    topics: dict[str, tuple[str, int]]
    trajectory: Trajectory | None = None
    cmd_t: FloatArray = field(default_factory=lambda: np.zeros(0))
    cmd_vx: FloatArray = field(default_factory=lambda: np.zeros(0))
    cmd_wz: FloatArray = field(default_factory=lambda: np.zeros(0))
    scan_log_t: FloatArray = field(default_factory=lambda: np.zeros(0))
    scan_stamp: FloatArray = field(default_factory=lambda: np.zeros(0))
    scan_free: FloatArray = field(default_factory=lambda: np.zeros(0))
    scan_min: FloatArray = field(default_factory=lambda: np.zeros(0))
    laser_yaw: float = 0.0
    grid: OccupancyGrid | None = None
    plans: list[FloatArray] = field(default_factory=list)
    goals: list[GoalEvent] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    footprint: FloatArray | None = None
    obstacle_t: FloatArray = field(default_factory=lambda: np.zeros(0))
    obstacles: list[tuple[FloatArray, FloatArray]] = field(default_factory=list)


def _trajectory(topic: str, msgs: list[Odometry]) -> Trajectory:
    n = len(msgs)
    arr = np.empty((n, 6))
    for i, m in enumerate(msgs):
        p, q, tw = m.pose.pose.position, m.pose.pose.orientation, m.twist.twist
        arr[i] = (m.header.stamp, p.x, p.y, math.atan2(2.0 * (q.w * q.z + q.x * q.y),
                                                       1.0 - 2.0 * (q.y * q.y + q.z * q.z)),
                  math.hypot(tw.linear.x, tw.linear.y), tw.angular.z)
    order = np.argsort(arr[:, 0], kind="stable")
    arr = arr[order]
    first = msgs[0] if msgs else Odometry()
    return Trajectory(topic, first.header.frame_id, first.child_frame_id or "base_link",
                      arr[:, 0], arr[:, 1:3], arr[:, 3], arr[:, 4], arr[:, 5])


def _goals(statuses: list[tuple[float, GoalStatusArray]],
           poses: list[tuple[float, PoseStamped]]) -> list[GoalEvent]:
    started: dict[bytes, float] = {}
    ended: dict[bytes, tuple[float, int]] = {}
    for log_t, arr in statuses:
        for s in arr.status_list:
            gid = s.goal_info.goal_id
            started.setdefault(gid, s.goal_info.stamp)
            if s.terminal and gid not in ended:
                ended[gid] = (log_t, s.status)
    events = []
    for i, (gid, start) in enumerate(sorted(started.items(), key=lambda kv: kv[1])):
        near = [p for t, p in poses if abs(t - start) < 1e-6]
        pose = near[0] if near else (poses[i][1] if i < len(poses) else None)
        stop, code = ended.get(gid, (None, 0))
        events.append(GoalEvent(i + 1, start, stop,
                                STATUS_NAMES.get(code, "UNKNOWN") if stop is not None
                                else "UNFINISHED",
                                (pose.pose.position.x, pose.pose.position.y) if pose else None))
    return events


def load_bag(path: str | FsPath, forward_half_angle: float = math.radians(15.0),
             trajectory_topic: str | None = None) -> BagData:
    """Read the report's inputs from ``path`` (see the module docstring)."""
    with BagReader(path) as bag:
        info = bag.topics()
        data = BagData(FsPath(path), bag.start_time, bag.end_time,
                       {k: (v.ros_type, v.count) for k, v in info.items()})
        expected = dict(EXPECTED)
        candidates = list(TRAJECTORY_TOPICS)
        if trajectory_topic:
            expected[trajectory_topic] = EXPECTED["/odom"]
            candidates = [trajectory_topic]
            if trajectory_topic not in info:
                data.notes.append(f"{trajectory_topic} is not in the bag: no trajectory")
        wanted = [t for t, ros in expected.items() if t in info and info[t].ros_type == ros]
        for t, ros in expected.items():
            if t in info and info[t].ros_type != ros:
                data.notes.append(f"{t} is {info[t].ros_type}, not {ros}: not used")
        traj_topic = next((t for t in candidates if t in wanted), None)
        odometry_like = {*TRAJECTORY_TOPICS, *candidates}
        odoms: list[Odometry] = []
        scans: list[tuple[float, LaserScan]] = []
        cmds: list[tuple[float, float, float]] = []
        statuses: list[tuple[float, GoalStatusArray]] = []
        poses: list[tuple[float, PoseStamped]] = []
        obstacle_t: list[float] = []
        tree = TransformTree(cache_time=1e9)
        read = [t for t in wanted if t not in odometry_like or t == traj_topic]
        for item in bag.messages(read):
            msg = item.msg
            if item.topic == traj_topic and isinstance(msg, Odometry):
                odoms.append(msg)
            elif isinstance(msg, LaserScan):
                scans.append((item.log_time, msg))
            elif isinstance(msg, TwistMsg):
                cmds.append((item.log_time, msg.linear.x, msg.angular.z))
            elif isinstance(msg, OccupancyGrid):
                data.grid = msg
            elif isinstance(msg, Path):
                data.plans.append(np.array(msg.as_array()[:, :2]))
            elif isinstance(msg, GoalStatusArray):
                statuses.append((item.log_time, msg))
            elif isinstance(msg, PoseStamped):
                poses.append((item.log_time, msg))
            elif isinstance(msg, Marker) and len(msg.points) >= 3:
                outline = np.array([(q.x, q.y) for q in msg.points], dtype=np.float64)
                closed = np.allclose(outline[0], outline[-1])
                data.footprint = outline[:-1] if closed else outline
            elif isinstance(msg, MarkerArray):
                obstacle_t.append(item.log_time)
                data.obstacles.append(obstacle_shapes(msg))
            elif isinstance(msg, TFMessage):
                try:
                    tree.apply_tf_message(msg, True)
                except NavstackError as exc:
                    data.notes.append(f"/tf_static: {exc}")
    if traj_topic is not None and odoms:
        data.trajectory = _trajectory(traj_topic, odoms)
    if cmds:
        c = np.array(cmds)
        data.cmd_t, data.cmd_vx, data.cmd_wz = c[:, 0], c[:, 1], c[:, 2]
    if scans:
        _scan_arrays(data, scans, tree, forward_half_angle)
    data.goals = _goals(statuses, poses)
    data.obstacle_t = np.array(obstacle_t, dtype=np.float64)
    return data


def _scan_arrays(data: BagData, scans: list[tuple[float, LaserScan]], tree: TransformTree,
                 half_angle: float) -> None:
    base = data.trajectory.child_frame if data.trajectory is not None else "base_link"
    frame = scans[0][1].header.frame_id
    if frame and frame != base:
        try:
            data.laser_yaw = tree.lookup_pose2d(base, frame).theta
        except NavstackError:
            data.notes.append(f"no static transform {base} -> {frame} in /tf_static: the "
                              f"laser is taken to face forward")
    n = len(scans)
    data.scan_log_t = np.fromiter((t for t, _ in scans), np.float64, n)
    data.scan_stamp = np.fromiter((s.header.stamp for _, s in scans), np.float64, n)
    free = np.empty(n)
    nearest = np.empty(n)
    for i, (_, s) in enumerate(scans):
        angles = s.angles() + data.laser_yaw
        free[i] = forward_free_distance(s.ranges, angles, s.range_min, s.range_max, half_angle)
        r = np.asarray(s.ranges, dtype=np.float64)
        ok = np.isfinite(r) & (r >= s.range_min) & (r <= s.range_max)
        nearest[i] = float(r[ok].min()) if ok.any() else math.inf
    data.scan_free, data.scan_min = free, nearest

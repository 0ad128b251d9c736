"""The rover's mission state: its blackboard and the posts it has seen.

The rover's py_trees tree (``FIELD-ROBOTS.md``, the planetary rover) keeps its state on a
blackboard: the current task (a GPS or odom goal and the marker ids to find there), the
spiral points still to visit, the posts detected so far "stored by marker id in the odom
frame", the posts visited, the gate tries.  :class:`RoverBlackboard` is that state;
*stop mission* resets it (:meth:`RoverBlackboard.reset`).

:class:`RoverContext` is the mission layer's :class:`~navstack.missions.context.
MissionContext` in the rover's frame (``odom``: every GPS goal is placed in odom, as on the
rover) with a :class:`PostTracker`: every ArUco detection (``/aruco/markers``, camera
optical frame) goes through TF at the image's stamp into odom; a post's centre is the
marker's position pushed back by the post radius along the line of sight (the marker is
on the post's face); the post's estimate is the inverse-variance mean of its sightings,
weighting each by ``range^-4`` (PnP depth error grows with the square of the range), so
the close sightings of an approach dominate the far first ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from navstack.core.errors import NavstackError
from navstack.core.msgs.fiducial_msgs import ArucoMarkerArray
from navstack.core.rotations import transform_to_matrix
from navstack.missions.context import MissionContext
from navstack.runtime.bus import SENSOR_DATA

__all__ = ["PostEstimate", "PostTracker", "RoverBlackboard", "RoverContext", "RoverTask",
           "TaskStatus"]


class TaskStatus(Enum):
    IDLE = "idle"
    RUNNING = "running"
    PAUSED = "paused"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELED = "canceled"


@dataclass(frozen=True)
class RoverTask:
    """One leg: a GPS goal (``latitude``/``longitude``) or an odom goal (``xy``), and the
    marker ids to find there: none (GNSS-only leg), one post, or a gate's two posts."""

    name: str
    post_ids: tuple[int, ...] = ()
    latitude: float | str | None = None
    longitude: float | str | None = None
    xy: tuple[float, float] | None = None

    @property
    def kind(self) -> str:
        return {0: "gnss", 1: "post", 2: "gate"}.get(len(self.post_ids), "posts")


@dataclass
class PostEstimate:
    """A post's centre in odom [m] from its sightings (module docstring)."""

    marker_id: int
    sightings: list[tuple[float, float, float, float]] = field(default_factory=list)
    """(stamp, x, y, range) per detection."""

    @property
    def count(self) -> int:
        return len(self.sightings)

    @property
    def last_seen(self) -> float:
        return self.sightings[-1][0] if self.sightings else -math.inf

    @property
    def closest_range(self) -> float:
        return min((s[3] for s in self.sightings), default=math.inf)

    def xy(self) -> tuple[float, float]:
        a = np.asarray(self.sightings[-200:], dtype=np.float64)
        w = 1.0 / np.maximum(a[:, 3], 1.0) ** 4
        return float(np.sum(w * a[:, 1]) / np.sum(w)), float(np.sum(w * a[:, 2]) / np.sum(w))


class PostTracker:
    """Detected posts by marker id in ``frame`` (module docstring)."""

    def __init__(self, ctx: MissionContext, frame: str, post_radius: float = 0.15,
                 max_range: float = 15.0, topic: str = "/aruco/markers") -> None:
        self.ctx = ctx
        self.frame = frame
        self.post_radius = post_radius
        self.max_range = max_range
        self.posts: dict[int, PostEstimate] = {}
        self.tf_misses = 0
        self._sub = ctx.runtime.bus.subscribe(topic, ArucoMarkerArray, self._on_markers,
                                              SENSOR_DATA)

    def clear(self) -> None:
        self.posts.clear()

    def close(self) -> None:
        self._sub.unsubscribe()

    def _on_markers(self, msg: ArucoMarkerArray) -> None:
        if not msg.markers:
            return
        tf = self.ctx.runtime.tf
        try:
            ts = tf.lookup(self.frame, msg.header.frame_id, msg.header.stamp)
        except NavstackError:
            try:
                ts = tf.lookup(self.frame, msg.header.frame_id)
            except NavstackError:
                self.tf_misses += 1
                return
        t = transform_to_matrix(ts.transform)
        cam = t[:3, 3]
        for mk in msg.markers:
            p = mk.pose.pose.position
            local = np.array([p.x, p.y, p.z])
            rng = float(np.linalg.norm(local))
            if not math.isfinite(rng) or rng > self.max_range:
                continue
            world = t[:3, :3] @ local + cam
            dx, dy = world[0] - cam[0], world[1] - cam[1]
            d = math.hypot(dx, dy)
            if d < 1e-6:
                continue
            x = world[0] + self.post_radius * dx / d
            y = world[1] + self.post_radius * dy / d
            est = self.posts.setdefault(mk.id, PostEstimate(mk.id))
            est.sightings.append((float(msg.header.stamp), float(x), float(y), rng))

    def seen(self, marker_id: int, min_sightings: int = 3) -> bool:
        est = self.posts.get(marker_id)
        return est is not None and est.count >= min_sightings

    def visible(self, marker_id: int, now: float, within: float = 0.5) -> bool:
        est = self.posts.get(marker_id)
        return est is not None and now - est.last_seen <= within

    def xy(self, marker_id: int) -> tuple[float, float] | None:
        est = self.posts.get(marker_id)
        return None if est is None or not est.count else est.xy()


@dataclass
class RoverBlackboard:
    """The rover tree's blackboard (module docstring)."""

    task: RoverTask | None = None
    status: TaskStatus = TaskStatus.IDLE
    reason: str = ""
    goal_reached: bool = False
    """The GPS / odom goal of the task has been reached (the search may start)."""
    goal_odom: tuple[float, float] | None = None
    search_origin: tuple[float, float] | None = None
    points: list[tuple[float, float]] = field(default_factory=list)
    """Spiral points still to visit (odom)."""
    visited: set[int] = field(default_factory=set)
    point: tuple[float, float] | None = None
    """The spiral point being driven to."""
    gate_tries: int = 0
    gate_circled: bool = False
    gate_crossed_at: float | None = None
    started: float = 0.0
    goal_reached_at: float | None = None
    first_seen_at: float | None = None
    ended: float | None = None

    def reset(self) -> None:
        """Forget everything (the rover's *stop mission*)."""
        self.__init__()  # type: ignore[misc]

    def begin(self, task: RoverTask, now: float) -> None:
        self.reset()
        self.task, self.status, self.started = task, TaskStatus.RUNNING, now

    def finish(self, status: TaskStatus, reason: str, now: float) -> None:
        self.status, self.reason, self.ended = status, reason, now

    @property
    def targets(self) -> tuple[int, ...]:
        return self.task.post_ids if self.task is not None else ()


@dataclass
class RoverContext(MissionContext):
    """The mission context of the rover: odom frame, posts, blackboard, mode string."""

    global_frame: str = "odom"
    mode_topic: str = "/rover/mode"
    post_radius: float = 0.15
    camera_range: float = 15.0

    def __post_init__(self) -> None:
        super().__post_init__()
        self.bb = RoverBlackboard()
        self.tracker = PostTracker(self, self.global_frame, self.post_radius,
                                   self.camera_range)

    def close(self) -> None:
        self.tracker.close()
        super().close()

"""TransformTree: a tf2-like buffer of 3D rigid transforms between named frames.

Frames follow REP-105 (``map`` -> ``odom`` -> ``base_link`` -> sensor frames).  Each
edge is stored once, child -> parent, as a translation plus a unit quaternion
``(x, y, z, qx, qy, qz, qw)``.  Static edges (``/tf_static``) hold one value valid at
every time; dynamic edges (``/tf``) hold a time-sorted buffer that is pruned to
``cache_time`` seconds behind the newest stamp of that edge (tf2 ``BufferCore``'s
``cache_time``, default 10 s).

``lookup(target, source, t)`` returns the transform mapping points in ``source`` into
``target`` (tf2 ``lookupTransform(target_frame, source_frame, time)``): the chain runs
through the closest common ancestor, each dynamic edge interpolated at ``t`` (linear
translation, quaternion slerp, exact at samples).  ``t=None`` is tf2's ``Time(0)``: the
latest time every dynamic edge of the chain has data for.  Nothing is extrapolated
beyond a tolerance of :data:`TIME_TOLERANCE`; failures raise typed errors naming the
frames, the edge and the time window it holds.

Deviations from tf2, on purpose: a frame has exactly one parent for its lifetime and is
either static or dynamic (a second parent or a /tf vs /tf_static mix is almost always
two nodes publishing the same frame, so it raises :class:`FrameConflictError` instead of
silently re-parenting); a sample with an already-buffered stamp overwrites it (tf2
Noetic behaviour).
"""

from __future__ import annotations

import math
from bisect import bisect_left

from navstack.core.errors import (
    ConfigError,
    ConnectivityError,
    ExtrapolationError,
    FrameConflictError,
    InvalidMessage,
    UnknownFrameError,
    did_you_mean,
)
from navstack.core.msgs import (
    Header,
    Pose2D,
    Quaternion,
    TFMessage,
    Transform,
    TransformStamped,
    Vector3,
)

TIME_TOLERANCE = 1e-6
"""Lookups this close [s] outside an edge's window use the end sample instead of failing
(covers float rounding of stamps; ~4 ulp at Unix-epoch magnitudes)."""

QUATERNION_NORMALIZATION_TOLERANCE = 1e-2
"""Largest ``| |q|^2 - 1 |`` accepted (and renormalised), as tf2 ``BufferCore``."""

Tf = tuple[float, float, float, float, float, float, float]
"""A rigid transform ``(x, y, z, qx, qy, qz, qw)``."""

IDENTITY: Tf = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


# --- rigid transform algebra on 7-tuples (pure floats: fastest for short chains) ------
def tf_mul(a: Tf, b: Tf) -> Tf:
    """``a * b``: apply ``b`` then ``a`` (``T_ac = T_ab * T_bc``)."""
    ax, ay, az, qx, qy, qz, qw = a
    bx, by, bz, rx, ry, rz, rw = b
    # rotate b's translation by a's quaternion: v + 2w(u x v) + 2u x (u x v)
    cx, cy, cz = qy * bz - qz * by, qz * bx - qx * bz, qx * by - qy * bx
    cx, cy, cz = 2.0 * cx, 2.0 * cy, 2.0 * cz
    px = bx + qw * cx + (qy * cz - qz * cy)
    py = by + qw * cy + (qz * cx - qx * cz)
    pz = bz + qw * cz + (qx * cy - qy * cx)
    return (ax + px, ay + py, az + pz,
            qw * rx + qx * rw + qy * rz - qz * ry,
            qw * ry - qx * rz + qy * rw + qz * rx,
            qw * rz + qx * ry - qy * rx + qz * rw,
            qw * rw - qx * rx - qy * ry - qz * rz)


def tf_inverse(a: Tf) -> Tf:
    """Inverse rigid transform: ``tf_mul(a, tf_inverse(a)) == IDENTITY``."""
    x, y, z, qx, qy, qz, qw = a
    inv_rot: Tf = (0.0, 0.0, 0.0, -qx, -qy, -qz, qw)
    t = tf_mul(inv_rot, (x, y, z, 0.0, 0.0, 0.0, 1.0))
    return (-t[0], -t[1], -t[2], -qx, -qy, -qz, qw)


def _sinc(x: float) -> float:
    return 1.0 - x * x / 6.0 if abs(x) < 1e-4 else math.sin(x) / x


def tf_interpolate(a: Tf, b: Tf, f: float) -> Tf:
    """Linear translation and shortest-arc slerp rotation; ``f`` 0 gives ``a``, 1 ``b``.

    The arc angle uses ``2 atan2(|q1 - q0|, |q1 + q0|)`` and sinc weights, so the
    rotation rate is exactly constant even for tiny steps (no nlerp fallback).
    """
    ax, ay, az, x0, y0, z0, w0 = a
    bx, by, bz, x1, y1, z1, w1 = b
    if x0 * x1 + y0 * y1 + z0 * z1 + w0 * w1 < 0.0:
        x1, y1, z1, w1 = -x1, -y1, -z1, -w1
    diff = math.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2 + (z1 - z0) ** 2 + (w1 - w0) ** 2)
    summ = math.sqrt((x1 + x0) ** 2 + (y1 + y0) ** 2 + (z1 + z0) ** 2 + (w1 + w0) ** 2)
    theta = 2.0 * math.atan2(diff, summ)
    s = _sinc(theta)
    k0 = (1.0 - f) * _sinc((1.0 - f) * theta) / s
    k1 = f * _sinc(f * theta) / s
    qx, qy, qz, qw = k0 * x0 + k1 * x1, k0 * y0 + k1 * y1, k0 * z0 + k1 * z1, k0 * w0 + k1 * w1
    n = 1.0 / math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    return (ax + f * (bx - ax), ay + f * (by - ay), az + f * (bz - az),
            qx * n, qy * n, qz * n, qw * n)


def tf_from_msg(tr: Transform) -> Tf:
    """The 7-tuple of a ``geometry_msgs/Transform``."""
    v, q = tr.translation, tr.rotation
    return (v.x, v.y, v.z, q.x, q.y, q.z, q.w)


def tf_from_pose2d(p: Pose2D, z: float = 0.0) -> Tf:
    """Planar pose as a rigid transform (rotation about +z only)."""
    h = 0.5 * p.theta
    return (p.x, p.y, z, 0.0, 0.0, math.sin(h), math.cos(h))


def tf_to_pose2d(a: Tf) -> Pose2D:
    """Planar projection: x, y and the yaw of the rotation (roll/pitch dropped)."""
    _, _, _, qx, qy, qz, qw = a
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    return Pose2D(a[0], a[1], yaw if yaw != -math.pi else math.pi)


def tf_to_stamped(a: Tf, parent: str, child: str, stamp: float) -> TransformStamped:
    """Wrap a 7-tuple into a ``TransformStamped`` (``child`` expressed in ``parent``)."""
    return TransformStamped(Header(stamp, parent), child,
                            Transform(Vector3(a[0], a[1], a[2]),
                                      Quaternion(a[3], a[4], a[5], a[6])))


def _fmt_times(t: float, *window: float) -> list[str]:
    """Format times with 3 decimals, more if that would make ``t`` look like a bound."""
    p = 3
    while p < 9 and any(f"{t:.{p}f}" == f"{w:.{p}f}" for w in window):
        p += 3
    return [f"{v:.{p}f}" for v in (t, *window)]


# --- edges and chains -----------------------------------------------------------------
class _Edge:
    """The transform of ``child`` in ``parent``; static (one value) or a time buffer."""

    __slots__ = ("authority", "child", "data", "parent", "static", "times")

    def __init__(self, parent: str, child: str, static: bool, authority: str) -> None:
        self.parent, self.child, self.static, self.authority = parent, child, static, authority
        self.times: list[float] = []
        self.data: list[Tf] = []

    @property
    def name(self) -> str:
        return f"{self.parent}->{self.child}"

    def insert(self, stamp: float, value: Tf, cache_time: float) -> bool:
        """Buffer one sample (overwriting an equal stamp); prune; False if too old."""
        if self.static:
            self.times, self.data = [0.0], [value]
            return True
        times, data = self.times, self.data
        i = bisect_left(times, stamp)
        if i < len(times) and times[i] == stamp:
            data[i] = value
        else:
            times.insert(i, stamp)
            data.insert(i, value)
        cut = bisect_left(times, times[-1] - cache_time)
        if cut:
            del times[:cut]
            del data[:cut]
        return times[0] <= stamp

    def at(self, t: float) -> Tf | None:
        """Value at ``t`` (interpolated), or ``None`` outside the window (+ tolerance)."""
        if self.static:
            return self.data[0]
        times = self.times
        if t >= times[-1]:
            return self.data[-1] if t - times[-1] <= TIME_TOLERANCE else None
        if t <= times[0]:
            return self.data[0] if times[0] - t <= TIME_TOLERANCE else None
        i = bisect_left(times, t)
        t1 = times[i]
        if t1 == t:
            return self.data[i]
        t0 = times[i - 1]
        return tf_interpolate(self.data[i - 1], self.data[i], (t - t0) / (t1 - t0))


class _Chain:
    """Edges from ``source`` up to the common ancestor, and from ``target`` up to it."""

    __slots__ = ("down", "dynamic", "up")

    def __init__(self, up: list[_Edge], down: list[_Edge]) -> None:
        self.up, self.down = up, down
        self.dynamic = [e for e in (*up, *down) if not e.static]


class TransformTree:
    """Static and time-buffered dynamic transforms between frames (tf2 ``BufferCore``).

    ``cache_time`` [s] is how far behind an edge's newest stamp its samples are kept
    (tf2 ``Buffer`` ``cache_time``, default 10 s).
    """

    def __init__(self, cache_time: float = 10.0) -> None:
        if not cache_time > 0.0:
            raise ConfigError(f"must be a positive duration in seconds, got {cache_time}",
                              key_path="cache_time")
        self.cache_time = float(cache_time)
        self._edges: dict[str, _Edge] = {}  # child -> edge to its parent
        self._frames: set[str] = set()
        self._chains: dict[tuple[str, str], _Chain] = {}

    # --- insertion ----------------------------------------------------------------------
    def set_transform(self, ts: TransformStamped, is_static: bool = False,
                      authority: str = "") -> bool:
        """Add ``ts`` (``child_frame_id`` in ``header.frame_id``) to the tree.

        Returns False when a dynamic sample is older than ``cache_time`` behind the
        edge's newest stamp and was dropped (tf2 ``TF_OLD_DATA``).  Raises
        :class:`InvalidMessage` for empty frame ids, NaN/inf values or a quaternion whose
        squared norm is off by more than 0.01, and :class:`FrameConflictError` when the
        edge contradicts the tree (second parent, cycle, static/dynamic mix).
        """
        parent, child, stamp = ts.header.frame_id, ts.child_frame_id, float(ts.header.stamp)
        value = self._validated(ts, is_static)
        edge = self._edges.get(child)
        if edge is None:
            self._check_new_edge(parent, child, authority)
            edge = _Edge(parent, child, is_static, authority)
            self._edges[child] = edge
            self._frames.update((parent, child))
            self._chains.clear()
        elif edge.parent != parent:
            by = f" (published by '{edge.authority}')" if edge.authority else ""
            new = f"'{authority}'" if authority else "a new transform"
            raise FrameConflictError(
                f"frame '{child}' already has parent '{edge.parent}'{by}; {new} gives it "
                f"parent '{parent}': a frame has exactly one parent (REP-105 chain "
                f"map -> odom -> base_link); stop one of the two publishers")
        elif edge.static != is_static:
            kinds = ("static (/tf_static)", "dynamic (/tf)")
            old, now = (kinds[0], kinds[1]) if edge.static else (kinds[1], kinds[0])
            raise FrameConflictError(
                f"edge {edge.name} is {old} but a {now} transform arrived for it; "
                f"publish each frame on one of /tf or /tf_static")
        edge.authority = authority or edge.authority
        return edge.insert(stamp, value, self.cache_time)

    def add_static(self, parent: str, child: str, pose: Pose2D, z: float = 0.0) -> None:
        """Add a static planar mounting ``child`` at ``pose`` (and height ``z``) in ``parent``."""
        ts = tf_to_stamped(tf_from_pose2d(pose, z), parent, child, 0.0)
        self.set_transform(ts, is_static=True)

    def apply_tf_message(self, msg: TFMessage, is_static: bool, authority: str = "") -> int:
        """Ingest a ``/tf`` (``is_static=False``) or ``/tf_static`` message; count stored.

        One bad transform does not drop the good ones of the same message: all valid
        transforms are stored first, then the first rejection is re-raised.
        """
        stored = 0
        first_error: InvalidMessage | FrameConflictError | None = None
        for ts in msg.transforms:
            try:
                stored += self.set_transform(ts, is_static, authority)
            except (InvalidMessage, FrameConflictError) as exc:
                first_error = first_error or exc
        if first_error is not None:
            raise first_error
        return stored

    def clear(self) -> None:
        """Drop every dynamic edge and its samples, keep static edges (tf2
        ``BufferCore::clear``, used after a simulation reset or a backwards time jump).
        Frames only reachable through dynamic edges are forgotten until republished."""
        self._edges = {c: e for c, e in self._edges.items() if e.static}
        self._frames = {f for e in self._edges.values() for f in (e.parent, e.child)}
        self._chains.clear()

    def _validated(self, ts: TransformStamped, is_static: bool) -> Tf:
        parent, child = ts.header.frame_id, ts.child_frame_id

        def what() -> str:  # built only when reporting: this runs for every sample
            return f"transform {parent or '?'}->{child or '?'} at t={ts.header.stamp:.3f} s"

        if not parent or not child:
            raise InvalidMessage(f"{what()} has an empty frame id; set header.frame_id "
                                 f"(parent) and child_frame_id")
        if parent == child:
            raise FrameConflictError(f"{what()} maps frame '{child}' onto itself; "
                                     f"parent and child must differ")
        v = tf_from_msg(ts.transform)
        isfinite = math.isfinite
        if not (isfinite(v[0]) and isfinite(v[1]) and isfinite(v[2]) and isfinite(v[3])
                and isfinite(v[4]) and isfinite(v[5]) and isfinite(v[6])) or not (
                is_static or isfinite(ts.header.stamp)):
            raise InvalidMessage(f"{what()} contains NaN or inf; fix its publisher")
        n2 = v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]
        if abs(n2 - 1.0) > QUATERNION_NORMALIZATION_TOLERANCE:
            raise InvalidMessage(f"{what()} has a non-unit rotation quaternion "
                                 f"(|q|^2 = {n2:.4f}); normalise it (tf2 tolerance "
                                 f"{QUATERNION_NORMALIZATION_TOLERANCE})")
        k = 1.0 / math.sqrt(n2)
        return (v[0], v[1], v[2], v[3] * k, v[4] * k, v[5] * k, v[6] * k)

    def _check_new_edge(self, parent: str, child: str, authority: str) -> None:
        frame: str | None = parent
        while frame is not None:
            if frame == child:
                raise FrameConflictError(
                    f"adding edge {parent}->{child}{f' from {authority!r}' if authority else ''}"
                    f" would close a loop: '{parent}' already descends from '{child}'; "
                    f"transforms must form a tree")
            edge = self._edges.get(frame)
            frame = edge.parent if edge is not None else None

    # --- queries ------------------------------------------------------------------------
    def frames(self) -> list[str]:
        """Every frame seen, as parent or child, sorted."""
        return sorted(self._frames)

    def __contains__(self, frame: object) -> bool:
        return frame in self._frames

    def parent_of(self, frame: str) -> str | None:
        """Parent of ``frame``, ``None`` for a root.  Unknown frames raise."""
        self._require(frame)
        edge = self._edges.get(frame)
        return edge.parent if edge is not None else None

    def latest_time(self, frame: str) -> float | None:
        """Newest stamp of ``frame``'s edge to its parent; ``None`` if static or a root."""
        self._require(frame)
        edge = self._edges.get(frame)
        return None if edge is None or edge.static else edge.times[-1]

    def edge_samples(self, frame: str) -> list[TransformStamped]:
        """Buffered samples of ``frame``'s edge to its parent, oldest first (for checks)."""
        self._require(frame)
        edge = self._edges.get(frame)
        if edge is None:
            return []
        return [tf_to_stamped(v, edge.parent, edge.child, s)
                for s, v in zip(edge.times, edge.data, strict=True)]

    def describe(self) -> str:
        """One line per edge: kind, sample count, time window, authority (tf2 view_frames)."""
        lines = []
        for child in sorted(self._edges):
            e = self._edges[child]
            who = f", authority '{e.authority}'" if e.authority else ""
            if e.static:
                lines.append(f"{e.name}: static{who}")
            else:
                lo, hi = _fmt_times(e.times[0], e.times[-1])
                lines.append(f"{e.name}: dynamic, {len(e.times)} samples in [{lo}, {hi}] s{who}")
        return "\n".join(lines)

    def lookup(self, target: str, source: str, t: float | None = None) -> TransformStamped:
        """Transform mapping points in ``source`` into ``target`` at time ``t``.

        ``t=None`` uses the latest time common to the chain's dynamic edges (0.0 when the
        chain is all static).  The result's ``header.frame_id`` is ``target`` and its
        ``child_frame_id`` is ``source``.
        """
        value, stamp = self._resolve(target, source, t)
        return tf_to_stamped(value, target, source, stamp)

    def lookup_pose2d(self, target: str, source: str, t: float | None = None) -> Pose2D:
        """Planar projection (x, y, yaw) of :meth:`lookup`: the pose of ``source`` in
        ``target``.  Hot path: cached chain, float arithmetic, no message objects."""
        return tf_to_pose2d(self._resolve(target, source, t)[0])

    def can_transform(self, target: str, source: str, t: float | None = None) -> bool:
        """Whether :meth:`lookup` would succeed."""
        try:
            self._resolve(target, source, t)
        except (UnknownFrameError, ConnectivityError, ExtrapolationError):
            return False
        return True

    def _require(self, frame: str) -> None:
        if frame not in self._frames:
            known = ", ".join(sorted(self._frames)) or "none (the tree is empty)"
            raise UnknownFrameError(f"frame '{frame}' does not exist"
                                    f"{did_you_mean(frame, self._frames)}; known frames: {known}")

    def _root_path(self, frame: str) -> list[_Edge]:
        path = []
        edge = self._edges.get(frame)
        while edge is not None:
            path.append(edge)
            edge = self._edges.get(edge.parent)
        return path

    def _chain(self, target: str, source: str) -> _Chain:
        chain = self._chains.get((target, source))
        if chain is not None:
            return chain
        self._require(target)
        self._require(source)
        up, down = self._root_path(source), self._root_path(target)
        root_s = up[-1].parent if up else source
        root_t = down[-1].parent if down else target
        if root_s != root_t:
            raise ConnectivityError(f"cannot transform '{source}' to '{target}': they are not "
                                    f"connected (roots '{root_s}' and '{root_t}')")
        while up and down and up[-1] is down[-1]:  # drop the shared part above the ancestor
            up.pop()
            down.pop()
        chain = _Chain(up, down)
        self._chains[(target, source)] = chain
        return chain

    def _resolve(self, target: str, source: str, t: float | None) -> tuple[Tf, float]:
        chain = self._chain(target, source)
        when = t if t is not None else min((e.times[-1] for e in chain.dynamic), default=0.0)
        acc = IDENTITY
        for edge in chain.up:
            acc = tf_mul(self._edge_at(edge, when, target, source, t is None), acc)
        if chain.down:
            down = IDENTITY
            for edge in chain.down:
                down = tf_mul(self._edge_at(edge, when, target, source, t is None), down)
            acc = tf_mul(tf_inverse(down), acc)
        return acc, when

    @staticmethod
    def _edge_at(edge: _Edge, t: float, target: str, source: str, common: bool) -> Tf:
        value = edge.at(t)
        if value is not None:
            return value
        lo, hi = edge.times[0], edge.times[-1]
        ts, los, his = _fmt_times(t, lo, hi)
        way = "future" if t > hi else "past"
        note = " (latest common time)" if common else ""
        raise ExtrapolationError(
            f"lookup of '{source}' in '{target}' at t={ts} s{note} would extrapolate into the "
            f"{way}: edge {edge.name} holds [{los}, {his}] s")


def transform_pose2d(tree: TransformTree, pose: Pose2D, source: str, target: str,
                     t: float | None = None) -> Pose2D:
    """Express ``pose`` (given in ``source``) in ``target`` at time ``t`` (planar)."""
    return tree.lookup_pose2d(target, source, t).compose(pose)

"""CARMEN log reader: laser scans, reference poses and the odometry a SLAM front end needs.

CARMEN (Montemerlo, Roy, Thrun 2003) logs are text, one message per line, optionally
gzipped.  Messages used here:

``PARAM name value ...``
    Robot parameters (``robot_front_laser_max``, ``robot_frontlaser_offset``).
``ODOM x y theta tv rv accel timestamp host logger_timestamp``
    The wheel-odometry stream.
``FLASER n r1..rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp``
    Front laser: ``n`` beams over 180 degrees starting at -90 degrees.  With an odd
    ``n`` (181, 361) both ends are beams (increment ``pi/(n-1)``); with an even ``n``
    (180) the CARMEN convention is ``pi/n`` (-90 .. +89 degrees).
``ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn
m rem1..remm laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
forward_safety_dist side_safety_dist turn_axis timestamp host logger_timestamp``
    A laser with its own geometry (radians, metres).

Everything else (``#`` comments, ``RLASER``, ``NEFF``, ``SYNC``, ``TRUEPOS``,
``RAWLASER*``, ...) is counted in :attr:`CarmenLog.ignored`.  A truncated or garbled line
is skipped and recorded in :attr:`CarmenLog.skipped` with its line number and the reason;
it never aborts the read.  Readings at or beyond the laser's maximum range mean "no
return" (:attr:`CarmenScan.valid`, and ``inf`` in :meth:`CarmenScan.to_laser_scan`).

Odometry of the "corrected" benchmark logs (Kümmerle et al. 2009, the Radish releases of
Intel, ACES, CSAIL): the laser pose is the corrected *reference* pose, the laser's
``odom_*`` fields repeat it, and the ODOM stream is re-anchored at every scan: the first
ODOM line after a scan carries exactly that scan's reference pose, and the following
ODOM lines continue from that anchor by the raw odometry increments.  The raw motion
between scans ``k`` and ``k+1`` is therefore ``delta_k = anchor_k^-1 * last_odom_before_{k+1}``
and the drifting odometry a SLAM system must be fed is ``odom_0 = last ODOM before scan
0`` (identity if none), ``odom_{k+1} = odom_k * delta_k`` (see :func:`read_carmen`).  An
ordinary log without anchors gives each scan the last ODOM pose before it (or the laser
line's own odometry fields if the log has no ODOM lines).
"""

from __future__ import annotations

import gzip
import math
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import NavstackError
from navstack.core.msgs import Header, LaserScan

FloatArray = NDArray[np.float64]

#: Default FLASER maximum range [m] when no ``robot_front_laser_max`` PARAM is given
#: (CARMEN's ``robot_front_laser_max`` default).
DEFAULT_FLASER_MAX_RANGE = 50.0
LASER_KINDS = ("FLASER", "ROBOTLASER1")
_IDENTITY = (0.0, 0.0, 0.0)


class CarmenLogError(NavstackError):
    """A CARMEN log cannot be read at all (missing, a directory, not a log)."""


class CarmenLogNotFound(CarmenLogError, FileNotFoundError):
    """The CARMEN log path does not exist."""


@dataclass(frozen=True, slots=True)
class SkippedLine:
    """A line that was not used because it is truncated or garbled."""

    line_no: int
    reason: str


@dataclass(frozen=True, slots=True, eq=False)
class CarmenScan:
    """One laser scan with the poses that go with it.

    ``ranges`` float64 ``(n,)`` [m]; beam ``i`` points at ``angle_min + i*angle_increment``
    [rad] in the laser frame.  ``reference`` is the logged (corrected) robot pose and
    ``odom`` the raw odometry pose derived as described in the module docstring, both
    ``(x, y, theta)`` in their own world frames.  ``laser_offset`` is the laser's pose in
    the robot frame.  ``line_no`` is the 1-based line of the scan in the file.
    ``odom_gap`` is true when the log has an ODOM stream but no ODOM line came between the
    previous laser line and this one: the odometry *since the previous scan* is missing
    (its motion is counted as none), so the pose of this scan must not be predicted
    from it.
    """

    kind: str
    line_no: int
    timestamp: float
    ranges: FloatArray
    angle_min: float
    angle_increment: float
    range_max: float
    reference: FloatArray
    odom: FloatArray
    laser_offset: FloatArray
    odom_gap: bool = False

    @property
    def valid(self) -> NDArray[np.bool_]:
        """Beams with a return: finite, positive and below ``range_max``."""
        r = self.ranges
        return np.isfinite(r) & (r > 0.0) & (r < self.range_max)

    def angles(self) -> FloatArray:
        """Beam angles [rad] in the laser frame, one per range."""
        return self.angle_min + self.angle_increment * np.arange(self.ranges.size,
                                                                 dtype=np.float64)

    def to_laser_scan(self, frame_id: str = "base_scan") -> LaserScan:
        """``sensor_msgs/LaserScan`` with ``inf`` for beams without a return (REP-117)."""
        ranges = np.where(self.valid, self.ranges, np.inf).astype(np.float32)
        n = self.ranges.size
        return LaserScan(header=Header(stamp=self.timestamp, frame_id=frame_id),
                         angle_min=self.angle_min,
                         angle_max=self.angle_min + self.angle_increment * max(n - 1, 0),
                         angle_increment=self.angle_increment, range_min=0.0,
                         range_max=self.range_max, ranges=ranges)


@dataclass(frozen=True, slots=True, eq=False)
class CarmenLog:
    """The content of a CARMEN log: scans in file order, parameters and what was not used."""

    path: Path
    scans: list[CarmenScan]
    params: dict[str, str] = field(default_factory=dict)
    skipped: list[SkippedLine] = field(default_factory=list)
    ignored: dict[str, int] = field(default_factory=dict)
    anchored: bool = False

    def reference_poses(self) -> FloatArray:
        """``(K, 3)`` logged (corrected) robot poses of the scans."""
        return _stack([s.reference for s in self.scans])

    def odometry_poses(self) -> FloatArray:
        """``(K, 3)`` raw odometry poses of the scans (the SLAM input)."""
        return _stack([s.odom for s in self.scans])

    def timestamps(self) -> FloatArray:
        """``(K,)`` scan timestamps [s]."""
        return np.array([s.timestamp for s in self.scans], dtype=np.float64)


def _stack(poses: list[FloatArray]) -> FloatArray:
    return np.array(poses, dtype=np.float64).reshape(len(poses), 3)


class _BadLine(Exception):
    """Internal: the current line is unusable; the message is the reason."""


def _floats(tok: list[str], lo: int, hi: int) -> list[float]:
    try:
        return [float(t) for t in tok[lo:hi]]
    except ValueError:
        for i in range(lo, hi):
            try:
                float(tok[i])
            except ValueError:
                raise _BadLine(f"field {i} {tok[i]!r} is not a number") from None
        raise


def _count(tok: list[str], i: int, what: str) -> int:
    try:
        n = int(tok[i])
    except (ValueError, IndexError):
        shown = repr(tok[i]) if i < len(tok) else "(missing)"
        raise _BadLine(f"{what} count {shown} is not a non-negative integer") from None
    if n < 0:
        raise _BadLine(f"{what} count {tok[i]!r} is not a non-negative integer")
    return n


def _check_fields(tok: list[str], need: int, kind: str, what: str) -> None:
    """Fields through the timestamp are required; ``host logger_timestamp`` optional."""
    if not need - 2 <= len(tok) <= need:
        raise _BadLine(f"expected {need} fields for {kind}{what}, got {len(tok)}")


Pose = tuple[float, float, float]


def _pose(vals: list[float]) -> Pose:
    x, y, th = vals
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(th)):
        raise _BadLine("non-finite pose")
    return (x, y, th)


def _compose(a: Pose, b: Pose) -> Pose:
    """SE(2) ``a * b`` on float tuples (the per-line path avoids numpy overhead)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1],
            math.remainder(a[2] + b[2], 2.0 * math.pi))


def _between(a: Pose, b: Pose) -> Pose:
    """SE(2) ``a^-1 * b`` on float tuples."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, math.remainder(b[2] - a[2], 2.0 * math.pi))


@dataclass(slots=True)
class _RawScan:
    kind: str
    line_no: int
    timestamp: float
    ranges: FloatArray
    angle_min: float
    angle_increment: float
    range_max: float
    reference: Pose
    own_odom: Pose
    laser_offset: Pose
    odom_gap: bool = False


def _parse_flaser(tok: list[str], line_no: int, max_range: float,
                  offset: Pose) -> _RawScan:
    n = _count(tok, 1, "reading")
    _check_fields(tok, n + 11, "FLASER", f" with {n} readings")
    vals = _floats(tok, 2, n + 9)
    ranges = np.array(vals[:n], dtype=np.float64)
    if n < 2:
        raise _BadLine(f"FLASER needs at least 2 readings, got {n}")
    inc = math.pi / (n - 1) if n % 2 else math.pi / n
    return _RawScan("FLASER", line_no, vals[n + 6], ranges, -0.5 * math.pi, inc, max_range,
                    _pose(vals[n:n + 3]), _pose(vals[n + 3:n + 6]), offset)


def _parse_robotlaser1(tok: list[str], line_no: int) -> _RawScan:
    n = _count(tok, 8, "reading")
    m = _count(tok, 9 + n, "remission") if len(tok) > 9 + n else 0
    _check_fields(tok, n + m + 24, "ROBOTLASER1", f" with {n} readings and {m} remissions")
    head = _floats(tok, 1, 8)
    ranges = np.array(_floats(tok, 9, 9 + n), dtype=np.float64)
    tail = _floats(tok, 10 + n + m, 22 + n + m)
    start, _fov, res, max_range = head[1], head[2], head[3], head[4]
    if not (math.isfinite(res) and res > 0.0 and math.isfinite(max_range) and max_range > 0):
        raise _BadLine(f"angular resolution {res} and maximum range {max_range} must be > 0")
    laser, robot = _pose(tail[0:3]), _pose(tail[3:6])
    offset = _between(robot, laser)
    return _RawScan("ROBOTLASER1", line_no, tail[11], ranges, start, res, max_range,
                    robot, robot, offset)


def _read_text(path: Path) -> tuple[str, bool]:
    """Decoded file text and whether a gzip stream ended early (salvaged prefix)."""
    if not path.exists():
        raise CarmenLogNotFound(f"CARMEN log not found: {path} (check the path; logs may "
                                "be plain text or .gz)")
    if not path.is_file():
        raise CarmenLogError(f"CARMEN log path is not a file: {path}")
    data = path.read_bytes()
    truncated = False
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (EOFError, OSError, zlib.error):
            d = zlib.decompressobj(16 + zlib.MAX_WBITS)
            try:
                data = d.decompress(data)
            except zlib.error as exc:
                raise CarmenLogError(f"{path}: corrupt gzip data ({exc})") from None
            truncated = True
    return data.decode("utf-8", errors="replace"), truncated


def read_carmen(path: str | Path, kinds: tuple[str, ...] = LASER_KINDS) -> CarmenLog:
    """Read a CARMEN log (plain or gzipped, detected from the content).

    ``kinds`` selects which laser messages become scans (``FLASER``, ``ROBOTLASER1``);
    logs that record the same laser both ways should pass one of them.  The odometry of
    each scan follows the anchor rule in the module docstring: the anchor of scan ``k``
    is the first ODOM line after it if its pose equals the scan's reference pose
    exactly.  After a laser line that had to be skipped, the next ODOM line starts the
    new odometry segment (it is that scan's anchor in a corrected log).

    Raises :class:`CarmenLogNotFound` / :class:`CarmenLogError` if the file cannot be
    read; bad lines are reported in ``CarmenLog.skipped`` instead.
    """
    path = Path(path)
    text, truncated = _read_text(path)
    lines = text.splitlines()
    params: dict[str, str] = {}
    skipped: list[SkippedLine] = []
    ignored: dict[str, int] = {}
    raws: list[_RawScan] = []
    before: list[Pose | None] = []           # last ODOM before each scan
    acc: list[Pose] = []                     # odometry increment accumulated up to each scan
    max_range = DEFAULT_FLASER_MAX_RANGE
    offset: Pose = _IDENTITY
    last: Pose | None = None
    seg_start: Pose | None = None            # start of the current odometry segment
    seg_last: Pose | None = None
    seg_open = False                         # a laser line opened a segment awaiting ODOM
    check_ref: Pose | None = None            # reference pose the next ODOM may anchor to
    motion = _IDENTITY
    any_anchor = False
    any_odom = False
    odom_since_laser = True                  # an ODOM line since the last laser line
    for idx, line in enumerate(lines):
        tok = line.split()
        if not tok:
            continue
        tag = tok[0]
        try:
            if tag == "ODOM":
                _check_fields(tok, 10, "ODOM", "")
                pose = _pose(_floats(tok, 1, 8)[0:3])
                if seg_open:
                    if check_ref is not None and pose == check_ref:
                        any_anchor = True
                        seg_start = pose
                    else:
                        seg_start = last if last is not None and check_ref is not None else pose
                    seg_open, check_ref = False, None
                seg_last, last = pose, pose
                any_odom = odom_since_laser = True
            elif tag in LASER_KINDS:
                if seg_start is not None and seg_last is not None:
                    motion = _compose(motion, _between(seg_start, seg_last))
                seg_start = seg_last = None
                seg_open, check_ref = True, None
                if tag not in kinds:
                    ignored[tag] = ignored.get(tag, 0) + 1
                    continue
                raw = (_parse_flaser(tok, idx + 1, max_range, offset) if tag == "FLASER"
                       else _parse_robotlaser1(tok, idx + 1))
                raw.odom_gap = bool(raws) and not odom_since_laser
                odom_since_laser = False
                raws.append(raw)
                before.append(last)
                acc.append(motion)
                motion = _IDENTITY
                check_ref = raw.reference
            elif tag == "PARAM":
                if len(tok) < 3:
                    raise _BadLine(f"expected at least 3 fields for PARAM, got {len(tok)}")
                params[tok[1]] = tok[2]
                max_range, offset = _apply_param(tok[1], tok[2], max_range, offset)
            else:
                key = "#" if tag.startswith("#") else tag
                ignored[key] = ignored.get(key, 0) + 1
        except _BadLine as exc:
            skipped.append(SkippedLine(idx + 1, str(exc)))
    if truncated:
        skipped.append(SkippedLine(len(lines), "gzip stream ends early (truncated file); "
                                   "read up to here"))
    odom = _odometry(raws, before, acc, any_anchor)
    scans = [CarmenScan(r.kind, r.line_no, r.timestamp, r.ranges, r.angle_min,
                        r.angle_increment, r.range_max, np.array(r.reference),
                        np.array(o), np.array(r.laser_offset), any_odom and r.odom_gap)
             for r, o in zip(raws, odom, strict=True)]
    return CarmenLog(path, scans, params, skipped, ignored, any_anchor)


def _apply_param(name: str, value: str, max_range: float,
                 offset: Pose) -> tuple[float, Pose]:
    """Update the FLASER maximum range / mounting offset from a PARAM line."""
    try:
        v = float(value)
    except ValueError:
        return max_range, offset
    if name == "robot_front_laser_max" and math.isfinite(v) and v > 0.0:
        return v, offset
    if name == "robot_frontlaser_offset" and math.isfinite(v):
        return max_range, (v, 0.0, 0.0)
    return max_range, offset


def _odometry(raws: list[_RawScan], before: list[Pose | None], acc: list[Pose],
              anchored: bool) -> list[Pose]:
    """Odometry pose of every scan (module docstring): chained segment increments in an
    anchored log, the last ODOM pose before the scan otherwise."""
    out: list[Pose] = []
    for k, raw in enumerate(raws):
        prev = before[k]
        if not anchored:
            out.append(raw.own_odom if prev is None else prev)
        elif k == 0:
            out.append(_IDENTITY if prev is None else prev)
        else:
            out.append(_compose(out[-1], acc[k]))
    return out

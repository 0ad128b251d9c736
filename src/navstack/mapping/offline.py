"""Offline SLAM on a laser log: run the mapper, score it, time it.

:func:`run_carmen` reads a CARMEN log (:mod:`navstack.mapping.carmen`) into a
:class:`ScanLog` and :func:`run_log` feeds every scan with its odometry pose to a
:class:`~navstack.mapping.slam.SlamMapper`, finishes with the batch optimisation
(:meth:`SlamMapper.finalize`) and scores the final trajectory against the log's
reference poses (:func:`~navstack.mapping.map_metrics.trajectory_scores`: aligned ATE,
relative pose error at 1, 10 and 100 scans -- Kümmerle et al., "On measuring the
accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009 -- and the loop relation
error).  Simulated logs (:mod:`navstack.benchmarks.sim_logs`) use :func:`run_log` too.

*Log profile.*  slam_toolbox turns a scan into a graph node only after
``minimum_travel_distance`` (0.5 m) or ``minimum_travel_heading`` (0.5 rad) of motion and
``minimum_time_interval`` (0.5 s).  The "corrected" CARMEN benchmark logs are already
subsampled (one scan about every 0.7 m, or after a turn) but a raw or dense log has a
scan every few centimetres: the profile sets the travel gates to 0.3 m / 0.3 rad (nearly
every scan of a subsampled log becomes a node, every third of a log with a scan every
0.1 m) and drops the time gate (log clocks are coarse).  Every scan that is not a node is
still matched against the running buffer (``match_skipped_scans``) so that each scan of
the log gets a scored pose, and a submap is tried for loop closure every second node
(``loop_search_node_interval`` 2: CSAIL's ATE 0.10 -> 0.09 m; online, in the simulated
office, the default 3 maps better).  The free-space test against walkers
(``dynamic_point_margin``, :mod:`navstack.mapping.free_space`) is off for logs: on the
CARMEN logs it removed more wall points that a poor odometry step made look seen through
than people (Intel's first 300 scans with every second scan's odometry missing: ATE
0.118 m with main's fixed margin, 0.059 m with the margin scaled by the odometry's learned
error, 0.051 m without; CSAIL's consecutive-pair error 0.030 -> 0.038 m with it, measured
when it landed).  The loop-closure response gate against the links' typical response
(``loop_match_minimum_response_ratio``) is off for logs too: on the CARMEN laser data the
weak closures it drops were mostly right (with 0.75: Intel ATE 0.060 m and loop relations
0.040 m as without it, but ACES 0.079 -> 0.082 m and CSAIL 0.090 -> 0.098 m), while in the
simulated office they were the 5-12 cm biased ones.  So is the rule that a closure be
confirmed by one against another submap (``loop_match_confirmation_distinct_submaps``,
against the aliases of a repetitive warehouse): the logs' 180 degree lasers see a revisited
place from one direction, often from one submap only, and CSAIL lost 20 of its 86
closures (ATE 0.088 -> 0.140 m; Intel 0.057 -> 0.061, ACES 0.082 -> 0.085 m).  The
free-space test of closures (``loop_match_maximum_seen_through_ratio``) is off for logs
like the one against walkers: it rejected 2 of Intel's ~400 closures (ATE 0.0568 ->
0.0586 m) and none on ACES or CSAIL.  User parameters are applied on top of the
profile.

*Reference.*  The FLASER pose of an *anchored* (corrected) log is the reference pose;
in an ordinary log it is the robot's own (odometry) estimate, so there is no reference,
and no score (:attr:`CarmenLog.anchored`, the ODOM re-anchoring rule of ``carmen.py``).

*Timing.*  Each :meth:`SlamMapper.process_scan` call is timed with ``perf_counter``;
``wall_s`` is their sum plus :meth:`SlamMapper.finalize`.  ``ms_per_scan`` is the median
over the scans that became nodes; ``ms_first_10`` / ``ms_last_10`` the mean over all
scans of the first and last tenth of the log, so that a cost growing with the log's
length shows (:func:`warm_up` first, or the first tenth also pays for loading the
compiled kernels).  The log duration is ``max - min`` of the laser timestamps (logs
sometimes step back in time); when the timestamps do not tell the scans apart (the
CSAIL release prints them with 6 significant digits: two distinct values for 406 scans)
the duration and the speedup are unknown (``None``) rather than wrong.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import ConfigError, NavstackError
from navstack.core.geometry import se2_between, se2_compose
from navstack.mapping.carmen import CarmenScan, SkippedLine, read_carmen
from navstack.mapping.map_metrics import (
    RelativePoseError,
    TrajectoryScores,
    relative_pose_error,
    trajectory_scores,
)
from navstack.mapping.slam import LaserGeometry, SlamMapper
from navstack.mapping.slam_params import SlamParams

FloatArray = NDArray[np.float64]

__all__ = ["LOG_PROFILE", "OfflineResult", "OfflineSlamError", "Progress", "ScanLog",
           "ScanProgress",
           "log_duration", "metrics", "run_carmen", "run_log", "summary", "warm_up",
           "write_outputs", "write_trajectory_csv"]

#: Parameters under the user's for logs (module docstring, "Log profile").
LOG_PROFILE: dict[str, Any] = {"minimum_travel_distance": 0.3, "minimum_travel_heading": 0.3,
                               "minimum_time_interval": 0.0, "match_skipped_scans": True,
                               "loop_search_node_interval": 2, "dynamic_point_margin": 0.0,
                               "loop_match_minimum_response_ratio": 0.0,
                               "loop_match_confirmation_distinct_submaps": False,
                               "loop_match_maximum_seen_through_ratio": 0.0,
                               "odometry_scale_correction": True,
                               "odometry_edge_weak_directions": True}
#: Readings below this are not returns (CARMEN writes 0 for "no echo" on some lasers).
LASER_RANGE_MIN = 0.01
#: How many skipped lines the summary lists one by one (all are counted).
SKIPPED_SHOWN = 5


class OfflineSlamError(NavstackError):
    """An offline SLAM run cannot start or produce output (no scans, wrong mode)."""


@dataclass(frozen=True)
class ScanLog:
    """Scans to map: ``ranges`` (one array per scan), ``odometry`` ``(K, 3)`` (a row of
    NaN: no odometry for that scan), ``odom_gaps`` ``(K,)`` (the odometry since the
    previous scan is missing), ``stamps`` ``(K,)`` [s], the laser and the reference poses
    ``(K, 3)`` or ``None``; ``name`` says where it came from."""

    name: str
    laser: LaserGeometry
    ranges: Sequence[NDArray[np.floating]]
    odometry: FloatArray
    odom_gaps: NDArray[np.bool_]
    stamps: FloatArray
    reference: FloatArray | None = None


Progress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: called as a run moves through its stages."""


@dataclass(frozen=True)
class ScanProgress:
    """What :func:`run_log` reports to its ``detail`` callback while mapping: scans done
    of all, graph nodes, loop closures and the median ms per node of the last 200."""

    scans: int
    total: int
    nodes: int
    loop_closures: int
    ms_per_scan: float


@dataclass
class OfflineResult:
    """What :func:`run_carmen` / :func:`run_log` produced.

    ``trajectory`` / ``odometry`` / ``reference`` are ``(K, 3)`` poses ``(x, y, theta)``
    [m, rad] of the K processed scans (final map poses after the batch optimisation, the
    drifting odometry fed to SLAM, the log's reference poses or ``None``); ``stamps`` the
    ``(K,)`` laser timestamps [s].  ``skipped`` lists the log lines not used (the reader's
    garbled / truncated lines and scans whose laser geometry differs from the first one).
    ``scores`` / ``odometry_scores`` hold the global metrics of the trajectory and of the
    odometry alone; ``scan_ms`` the ``(K,)`` time of each ``process_scan`` call.
    """

    log_path: Path
    mapper: SlamMapper
    trajectory: FloatArray
    odometry: FloatArray
    reference: FloatArray | None
    stamps: FloatArray
    node_index: NDArray[np.int64]
    rpe: RelativePoseError | None
    odometry_rpe: RelativePoseError | None
    wall_s: float
    ms_per_scan: float
    log_duration_s: float | None
    speedup: float | None
    skipped: list[SkippedLine] = field(default_factory=list)
    ignored: dict[str, int] = field(default_factory=dict)
    scans_in_log: int = 0
    overrides: dict[str, Any] = field(default_factory=dict)
    scores: TrajectoryScores | None = None
    odometry_scores: TrajectoryScores | None = None
    scan_ms: FloatArray = field(default_factory=lambda: np.zeros(0))
    odometry_gaps: int = 0

    @property
    def scans(self) -> int:
        """Number of scans fed to the mapper."""
        return int(self.trajectory.shape[0])

    def tenth_ms(self) -> tuple[float, float]:
        """Mean ms per scan over the first and the last tenth of the log (NaN if fewer
        than 10 scans)."""
        k = self.scan_ms.size // 10
        if k == 0:
            return math.nan, math.nan
        return float(self.scan_ms[:k].mean()), float(self.scan_ms[-k:].mean())


def _laser(scan: CarmenScan) -> LaserGeometry:
    return LaserGeometry.uniform(scan.angle_min, scan.angle_increment, scan.ranges.size,
                                 LASER_RANGE_MIN, scan.range_max,
                                 mount=[float(v) for v in scan.laser_offset])


def _same_geometry(a: CarmenScan, b: CarmenScan) -> bool:
    return (a.ranges.size == b.ranges.size and a.angle_min == b.angle_min
            and a.angle_increment == b.angle_increment and a.range_max == b.range_max
            and bool(np.array_equal(a.laser_offset, b.laser_offset)))


def log_params(overrides: Mapping[str, Any] | None, file: str = "") -> SlamParams:
    """:data:`LOG_PROFILE` with ``overrides`` on top, validated (``file`` names the
    parameter file in errors); ``mode: localization`` is refused."""
    prefix = "slam_toolbox.ros__parameters" if file else ""
    params = SlamParams.from_mapping({**LOG_PROFILE, **dict(overrides or {})}, file=file,
                                     key_path=prefix)
    if params.mode != "mapping":
        raise ConfigError(f"mode '{params.mode}' cannot build a map from a log", file=file,
                          key_path=f"{prefix}.mode" if prefix else "mode",
                          suggestion="use mode: mapping for offline SLAM")
    return params


def log_duration(stamps: FloatArray) -> float | None:
    """``max - min`` of the stamps [s], or ``None`` when fewer than half the scans have
    distinct stamps (the log's clock is too coarse to time them)."""
    if stamps.size < 2 or np.unique(stamps).size * 2 < stamps.size:
        return None
    return float(stamps.max() - stamps.min())


def warm_up() -> None:
    """Load every compiled kernel SLAM uses (numba's cache) with a tiny synthetic run, so
    that the timing of a real run starts warm."""
    angles = np.linspace(-math.pi / 2, math.pi / 2, 91)
    laser = LaserGeometry(angles, 0.01, 10.0)
    mapper = SlamMapper(log_params({"loop_match_submap_size": 2}), laser)
    for k in range(8):
        x = 0.3 * k
        # a room 8 m x 6 m seen from (x, 0)
        c, s = np.cos(angles), np.sin(angles)
        with np.errstate(divide="ignore"):
            tx = np.where(c > 1e-9, (4.0 - x) / c, np.inf)
            ty = np.where(np.abs(s) > 1e-9, 3.0 / np.abs(s), np.inf)
        mapper.process_scan(np.minimum(tx, ty), [x, 0.0, 0.0], float(k), odom_gap=k == 7)
    mapper.finalize()


def run_log(log: ScanLog, params: SlamParams,
            progress: Progress | None = None,
            detail: Callable[[ScanProgress], None] | None = None,
            progress_period: float = 1.0) -> tuple[SlamMapper, FloatArray, FloatArray,
                                                   NDArray[np.int64], float]:
    """Feed every scan of ``log`` to a new mapper and optimise at the end.

    Returns the mapper, the final trajectory ``(K, 3)`` (every scan, nodes and the scans
    between them), the time of each ``process_scan`` call [ms], the node index of each
    scan and the wall time [s] (process_scan calls plus the final optimisation).
    ``progress`` hears the stages ``mapping`` (scans done of all, about every
    ``progress_period`` seconds) and ``optimise``; ``detail`` gets a
    :class:`ScanProgress` as often and at the end of the mapping stage."""
    report = progress or _silent
    mapper = SlamMapper(params, log.laser)
    k_total = len(log.ranges)
    anchors = np.zeros(k_total, dtype=np.int64)
    relative = np.zeros((k_total, 3))
    node_index = np.empty(k_total, dtype=np.int64)
    scan_ms = np.zeros(k_total)
    wall = 0.0
    node_ms: list[float] = []
    last_report = time.perf_counter()
    report("mapping", 0, k_total)
    for k in range(k_total):
        odom = log.odometry[k]
        t0 = time.perf_counter()
        made = mapper.process_scan(log.ranges[k], None if np.isnan(odom).any() else odom,
                                   float(log.stamps[k]), odom_gap=bool(log.odom_gaps[k]))
        dt = time.perf_counter() - t0
        wall += dt
        scan_ms[k] = 1e3 * dt
        if made:
            node_ms.append(1e3 * dt)
        node_index[k] = len(mapper.nodes) - 1
        anchor = mapper.last_scan
        anchors[k], relative[k] = (anchor[0], anchor[1]) if anchor else (0, np.zeros(3))
        if t0 - last_report >= progress_period:
            last_report = t0
            report("mapping", k + 1, k_total)
            if detail is not None:
                detail(_progress(mapper, k + 1, k_total, node_ms))
    if detail is not None:
        detail(_progress(mapper, k_total, k_total, node_ms))
    report("mapping", k_total, k_total)
    report("optimise", 0, 1)
    t0 = time.perf_counter()
    mapper.finalize()
    poses = mapper.poses()
    trajectory = se2_compose(poses[anchors], relative) if k_total else np.zeros((0, 3))
    _register_lone_scans(mapper, log, trajectory, node_index)
    wall += time.perf_counter() - t0
    report("optimise", 1, 1)
    return mapper, trajectory, scan_ms, node_index, wall


def _register_lone_scans(mapper: SlamMapper, log: ScanLog, trajectory: FloatArray,
                         node_index: NDArray[np.int64]) -> None:
    """Offline smoothing of the scans that had no odometry (never nodes): each is
    matched against the final map around the pose interpolated (by time) between the
    nodes before and after it -- the future an online run lacks -- and placed at that
    interpolation when nothing fits there."""
    lone = np.flatnonzero(np.isnan(log.odometry).any(axis=1))
    if lone.size == 0 or not mapper.nodes:
        return
    poses = mapper.poses()
    count = len(mapper.nodes)
    # the scan that made each node (node_index steps up there)
    made = np.flatnonzero(np.diff(np.r_[-1, node_index]) > 0)
    timed = log_duration(log.stamps) is not None  # else interpolate by scan count
    for k in lone:
        before = int(node_index[k])
        if before < 0 or before + 1 >= count or made.size != count:
            continue
        after = before + 1
        a, b = int(made[before]), int(made[after])
        span = log.stamps[b] - log.stamps[a]
        f = ((log.stamps[k] - log.stamps[a]) / span if timed and span > 0
             else (k - a) / max(b - a, 1))
        f = min(max(f, 0.0), 1.0)
        step = se2_between(poses[before], poses[after])
        guess = se2_compose(poses[before], step * f)
        # the scan was taken somewhere between its neighbours: the clock's fraction
        # first, then guesses along the step one search window apart (a robot that
        # stood still, then drove, breaks the clock's interpolation), and the online
        # placement (its relation to the node before, now optimised)
        along = np.linspace(0.0, 1.0, 2 + int(math.hypot(step[0], step[1])
                                               / mapper.params.correlation_search_space_dimension))
        guesses = [guess, *(se2_compose(poses[before], step * g) for g in along),
                   trajectory[k].copy()]
        pose = mapper.register(log.ranges[int(k)], guesses)
        # no local fit: the interpolation between the neighbours (1-2 scan spacings
        # apart) is closer than the online placement, which had only the past
        trajectory[k] = guess if pose is None else pose


def _silent(stage: str, done: int, total: int) -> None:
    """The default :data:`Progress`: says nothing."""


def _progress(mapper: SlamMapper, done: int, total: int, node_ms: list[float]
              ) -> ScanProgress:
    recent = node_ms[-200:]
    return ScanProgress(done, total, len(mapper.nodes), mapper.stats.loop_closures,
                    statistics.median(recent) if recent else math.nan)


def read_scan_log(log_path: str | Path, max_scans: int | None = None,
                  progress: Progress | None = None
                  ) -> tuple[ScanLog, list[SkippedLine], dict[str, int], int, Path]:
    """A CARMEN log as a :class:`ScanLog` (scans with the first scan's laser geometry;
    the others are added to the skipped lines), with the skipped lines, the ignored line
    counts, the number of scans in the file and its path.  ``progress`` hears the stage
    ``read log`` (0/1, 1/1)."""
    report = progress or _silent
    report("read log", 0, 1)
    log = read_carmen(log_path)
    report("read log", 1, 1)
    if not log.scans:
        raise OfflineSlamError(f"{log.path}: no usable laser scans (FLASER / ROBOTLASER1 "
                               f"lines); {len(log.skipped)} lines skipped as garbled")
    first = log.scans[0]
    skipped = list(log.skipped)
    keep: list[int] = []
    for k, scan in enumerate(log.scans):
        if _same_geometry(first, scan):
            keep.append(k)
        else:
            skipped.append(SkippedLine(scan.line_no, (
                f"{scan.kind} with {scan.ranges.size} beams from {scan.angle_min:.4f} rad "
                f"step {scan.angle_increment:.6f}; the run's laser (line {first.line_no}) has "
                f"{first.ranges.size} from {first.angle_min:.4f} step "
                f"{first.angle_increment:.6f}")))
    skipped.sort(key=lambda s: s.line_no)
    if max_scans is not None:
        keep = keep[:max_scans]
    scans = [log.scans[k] for k in keep]
    scan_log = ScanLog(
        name=str(log.path), laser=_laser(first), ranges=[s.ranges for s in scans],
        odometry=np.array([s.odom for s in scans], dtype=np.float64).reshape(-1, 3),
        odom_gaps=np.array([s.odom_gap for s in scans], dtype=bool),
        stamps=np.array([s.timestamp for s in scans], dtype=np.float64),
        reference=(np.array([s.reference for s in scans], dtype=np.float64).reshape(-1, 3)
                   if log.anchored else None))
    return scan_log, skipped, dict(log.ignored), len(log.scans), log.path


def run_carmen(log_path: str | Path, params_overrides: Mapping[str, Any] | None = None, *,
               max_scans: int | None = None, params_file: str = "",
               progress: Progress | None = None,
               detail: Callable[[ScanProgress], None] | None = None) -> OfflineResult:
    """Run SLAM over the laser scans of a CARMEN log (plain or ``.gz``).

    ``params_overrides`` are slam_toolbox parameters applied over :data:`LOG_PROFILE`
    (``params_file`` names their file in error messages); ``max_scans`` stops after that
    many scans; ``progress`` hears the stages ``read log`` (0/1, 1/1), ``mapping`` (scans
    done of all, about once a second) and ``optimise``, ``detail`` the mapping's
    :class:`ScanProgress` as often.  Raises
    :class:`~navstack.mapping.carmen.CarmenLogError` if the log cannot be read,
    :class:`~navstack.core.errors.ConfigError` for bad parameters and
    :class:`OfflineSlamError` if the log holds no usable scan.  Garbled lines never abort
    the run: they are listed in :attr:`OfflineResult.skipped`.
    """
    if max_scans is not None and max_scans < 1:
        raise OfflineSlamError(f"max_scans must be at least 1, got {max_scans}")
    params = log_params(params_overrides, params_file)
    scan_log, skipped, ignored, in_log, path = read_scan_log(log_path, max_scans, progress)
    return score_run(scan_log, params, skipped=skipped, ignored=ignored, scans_in_log=in_log,
                     path=path, overrides=dict(params_overrides or {}), progress=progress,
                     detail=detail)


def score_run(scan_log: ScanLog, params: SlamParams, *, skipped: list[SkippedLine] | None = None,
              ignored: dict[str, int] | None = None, scans_in_log: int | None = None,
              path: Path | None = None, overrides: dict[str, Any] | None = None,
              progress: Progress | None = None,
              detail: Callable[[ScanProgress], None] | None = None) -> OfflineResult:
    """:func:`run_log` and the scores of its trajectory against the log's reference."""
    mapper, trajectory, scan_ms, node_index, wall = run_log(scan_log, params, progress,
                                                            detail)
    made = scan_ms[np.r_[True, np.diff(node_index) > 0]] if scan_ms.size else scan_ms
    ms = float(np.median(made)) if made.size else math.nan
    reference = scan_log.reference
    rpe = odo_rpe = scores = odo_scores = None
    odometry = scan_log.odometry
    if reference is not None and scan_log.stamps.size >= 2:
        rpe = relative_pose_error(trajectory, reference)
        scores = trajectory_scores(trajectory, reference)
        if np.isfinite(odometry).all():
            odo_rpe = relative_pose_error(odometry, reference)
            odo_scores = trajectory_scores(odometry, reference)
    duration = log_duration(scan_log.stamps)
    return OfflineResult(
        log_path=path or Path(scan_log.name), mapper=mapper, trajectory=trajectory,
        odometry=odometry, reference=reference, stamps=scan_log.stamps,
        node_index=node_index, rpe=rpe, odometry_rpe=odo_rpe, wall_s=wall, ms_per_scan=ms,
        log_duration_s=duration,
        speedup=None if duration is None or wall <= 0.0 else duration / wall,
        skipped=list(skipped or []), ignored=dict(ignored or {}),
        scans_in_log=len(scan_log.ranges) if scans_in_log is None else scans_in_log,
        overrides=dict(overrides or {}), scores=scores, odometry_scores=odo_scores,
        scan_ms=scan_ms, odometry_gaps=int(np.count_nonzero(scan_log.odom_gaps)))


# the summary and the files (kept importable from here)
from navstack.mapping.slam_outputs import (  # noqa: E402
    metrics,
    summary,
    write_outputs,
    write_trajectory_csv,
)

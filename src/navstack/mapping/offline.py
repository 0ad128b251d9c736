"""Offline SLAM on a CARMEN log: run the mapper, score it, write the map and the graph.

:func:`run_carmen` feeds every laser scan of a CARMEN log (:mod:`navstack.mapping.carmen`)
with its odometry pose to a :class:`~navstack.mapping.slam.SlamMapper`, finishes with the
batch optimisation (:meth:`SlamMapper.finalize`) and scores the final trajectory against
the log's reference poses with the relative pose error of Kümmerle et al., "On measuring
the accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009
(:func:`~navstack.mapping.map_metrics.relative_pose_error`, consecutive pairs).

*Log profile.*  slam_toolbox only turns a scan into a graph node after
``minimum_travel_distance`` (0.5 m) or ``minimum_travel_heading`` (0.5 rad) of motion and
``minimum_time_interval`` (0.5 s).  The "corrected" CARMEN benchmark logs are already
subsampled (one scan about every 0.7 m, or after a turn), and the reference poses exist
only for those scans, so the profile sets the three gates to 0: every scan of the log
becomes a node and gets a scored pose.  User parameters are applied on top of the profile.

*Reference.*  The FLASER pose of an *anchored* (corrected) log is the reference pose;
in an ordinary log it is the robot's own (odometry) estimate, so there is no reference,
and no score (:attr:`CarmenLog.anchored`, the ODOM re-anchoring rule of ``carmen.py``).

*Timing.*  Each :meth:`SlamMapper.process_scan` call is timed with ``perf_counter``;
``wall_s`` is their sum plus :meth:`SlamMapper.finalize`.  The log duration is
``max - min`` of the laser timestamps (logs sometimes step back in time); when the
timestamps do not tell the scans apart (the CSAIL release prints them with 6 significant
digits: two distinct values for 406 scans) the duration and the speedup are unknown
(``None``) rather than wrong.
"""

from __future__ import annotations

import json
import math
import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import ConfigError, NavstackError
from navstack.mapping.carmen import CarmenScan, SkippedLine, read_carmen
from navstack.mapping.g2o import write_g2o
from navstack.mapping.map_metrics import RelativePoseError, relative_pose_error
from navstack.mapping.slam import LaserGeometry, SlamMapper
from navstack.mapping.slam_io import save_posegraph
from navstack.mapping.slam_params import SlamParams

FloatArray = NDArray[np.float64]

__all__ = ["LOG_PROFILE", "OfflineResult", "OfflineSlamError", "log_duration", "metrics",
           "run_carmen", "summary", "write_outputs", "write_trajectory_csv"]

#: Parameters under the user's for CARMEN benchmark logs (module docstring, "Log profile").
LOG_PROFILE: dict[str, Any] = {"minimum_travel_distance": 0.0, "minimum_travel_heading": 0.0,
                               "minimum_time_interval": 0.0}
#: Readings below this are not returns (CARMEN writes 0 for "no echo" on some lasers).
LASER_RANGE_MIN = 0.01
#: How many skipped lines the summary lists one by one (all are counted).
SKIPPED_SHOWN = 5


class OfflineSlamError(NavstackError):
    """An offline SLAM run cannot start or produce output (no scans, wrong mode)."""


@dataclass
class OfflineResult:
    """What :func:`run_carmen` produced.

    ``trajectory`` / ``odometry`` / ``reference`` are ``(K, 3)`` poses ``(x, y, theta)``
    [m, rad] of the K processed scans (final map poses after the batch optimisation, the
    drifting odometry fed to SLAM, the log's reference poses or ``None``); ``stamps`` the
    ``(K,)`` laser timestamps [s].  ``skipped`` lists the log lines not used (the reader's
    garbled / truncated lines and scans whose laser geometry differs from the first one).
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

    @property
    def scans(self) -> int:
        """Number of scans fed to the mapper."""
        return int(self.trajectory.shape[0])


def _laser(scan: CarmenScan) -> LaserGeometry:
    return LaserGeometry.uniform(scan.angle_min, scan.angle_increment, scan.ranges.size,
                                 LASER_RANGE_MIN, scan.range_max,
                                 mount=[float(v) for v in scan.laser_offset])


def _same_geometry(a: CarmenScan, b: CarmenScan) -> bool:
    return (a.ranges.size == b.ranges.size and a.angle_min == b.angle_min
            and a.angle_increment == b.angle_increment and a.range_max == b.range_max
            and bool(np.array_equal(a.laser_offset, b.laser_offset)))


def _params(overrides: Mapping[str, Any] | None, file: str) -> SlamParams:
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


Progress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: called as a run moves through its stages."""


def run_carmen(log_path: str | Path, params_overrides: Mapping[str, Any] | None = None, *,
               max_scans: int | None = None, params_file: str = "",
               progress: Progress | None = None) -> OfflineResult:
    """Run SLAM over the laser scans of a CARMEN log (plain or ``.gz``).

    ``params_overrides`` are slam_toolbox parameters applied over :data:`LOG_PROFILE`
    (``params_file`` names their file in error messages); ``max_scans`` stops after that
    many scans.  Raises :class:`~navstack.mapping.carmen.CarmenLogError` if the log cannot
    be read, :class:`~navstack.core.errors.ConfigError` for bad parameters and
    :class:`OfflineSlamError` if the log holds no usable scan.  Garbled lines never abort
    the run: they are listed in :attr:`OfflineResult.skipped`.  ``progress`` hears the
    stages ``read log`` (0/1, 1/1), ``mapping`` (scans done of all) and ``optimise``.
    """
    if max_scans is not None and max_scans < 1:
        raise OfflineSlamError(f"max_scans must be at least 1, got {max_scans}")
    report = progress or (lambda _stage, _done, _total: None)
    params = _params(params_overrides, params_file)
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
    odometry = np.array([s.odom for s in scans], dtype=np.float64).reshape(-1, 3)
    stamps = np.array([s.timestamp for s in scans], dtype=np.float64)

    mapper = SlamMapper(params, _laser(first))
    node_index = np.empty(len(scans), dtype=np.int64)
    wall = 0.0
    processed: list[float] = []  # times of the calls that made a node
    report("mapping", 0, len(scans))
    for k, scan in enumerate(scans):
        t0 = time.perf_counter()
        made_node = mapper.process_scan(scan.ranges, scan.odom.tolist(), scan.timestamp)
        dt = time.perf_counter() - t0
        wall += dt
        if made_node:
            processed.append(dt)
        node_index[k] = len(mapper.nodes) - 1
        if k % 50 == 49:
            report("mapping", k + 1, len(scans))
    report("mapping", len(scans), len(scans))
    report("optimise", 0, 1)
    t0 = time.perf_counter()
    mapper.finalize()
    wall += time.perf_counter() - t0
    report("optimise", 1, 1)
    ms = 1e3 * statistics.median(processed) if processed else math.nan
    trajectory = mapper.trajectory(odometry, node_index)

    reference = (np.array([s.reference for s in scans], dtype=np.float64).reshape(-1, 3)
                 if log.anchored else None)
    rpe = odo_rpe = None
    if reference is not None and len(scans) >= 2:
        rpe = relative_pose_error(trajectory, reference)
        odo_rpe = relative_pose_error(odometry, reference)
    duration = log_duration(stamps)
    return OfflineResult(
        log_path=log.path, mapper=mapper, trajectory=trajectory, odometry=odometry,
        reference=reference, stamps=stamps, node_index=node_index, rpe=rpe,
        odometry_rpe=odo_rpe, wall_s=wall, ms_per_scan=ms, log_duration_s=duration,
        speedup=None if duration is None or wall <= 0.0 else duration / wall,
        skipped=skipped, ignored=dict(log.ignored), scans_in_log=len(log.scans),
        overrides=dict(params_overrides or {}))


def _rpe_dict(rpe: RelativePoseError | None) -> dict[str, float | int] | None:
    if rpe is None:
        return None
    return {"trans_mean_m": rpe.trans_mean_m, "trans_std_m": rpe.trans_std_m,
            "rot_mean_deg": rpe.rot_mean_deg, "rot_std_deg": rpe.rot_std_deg,
            "pairs": rpe.pairs}


def metrics(result: OfflineResult) -> dict[str, float]:
    """The run's numbers under the ``navstack bench slam`` metric names without the log
    prefix: ``trans_err_m``, ``trans_err_std_m``, ``rot_err_deg``, ``rot_err_std_deg``
    (only with a reference), ``ms_per_scan``, ``speedup`` (only with a log duration),
    ``scans``, ``loop_closures``."""
    out: dict[str, float] = {"scans": float(result.scans),
                             "loop_closures": float(result.mapper.stats.loop_closures)}
    if result.rpe is not None:
        out.update(trans_err_m=result.rpe.trans_mean_m, trans_err_std_m=result.rpe.trans_std_m,
                   rot_err_deg=result.rpe.rot_mean_deg, rot_err_std_deg=result.rpe.rot_std_deg)
    if math.isfinite(result.ms_per_scan):
        out["ms_per_scan"] = result.ms_per_scan
    if result.speedup is not None:
        out["speedup"] = result.speedup
    return out


def summary(result: OfflineResult, files: Mapping[str, str] | None = None) -> dict[str, Any]:
    """JSON-ready summary of a run (written as ``summary.json`` by :func:`write_outputs`)."""
    stats = result.mapper.stats
    return {
        "metrics": metrics(result),
        "log": str(result.log_path),
        "scans_in_log": result.scans_in_log,
        "scans": result.scans,
        "nodes": len(result.mapper.nodes),
        "loop_closures": stats.loop_closures,
        "loop_attempts": stats.loop_attempts,
        "match_failures": stats.match_failures,
        "rpe": _rpe_dict(result.rpe),
        "odometry_rpe": _rpe_dict(result.odometry_rpe),
        "reference": ("corrected FLASER poses" if result.reference is not None
                      else "none (the log is not an anchored 'corrected' release)"),
        "ms_per_scan": result.ms_per_scan if math.isfinite(result.ms_per_scan) else None,
        "wall_s": result.wall_s,
        "log_duration_s": result.log_duration_s,
        "speedup": result.speedup,
        "skipped_lines": {"count": len(result.skipped),
                          "first": [{"line": s.line_no, "reason": s.reason}
                                    for s in result.skipped[:SKIPPED_SHOWN]]},
        "ignored_lines": result.ignored,
        "params": {**LOG_PROFILE, **result.overrides},
        "files": dict(files or {}),
    }


def write_trajectory_csv(result: OfflineResult, path: Path) -> None:
    """``stamp,x,y,theta,ref_x,ref_y,ref_theta`` per scan (reference columns empty when
    the log has no reference)."""
    rows = ["stamp,x,y,theta,ref_x,ref_y,ref_theta"]
    ref = result.reference
    for k in range(result.scans):
        est = ",".join(repr(float(v)) for v in result.trajectory[k])
        tail = ",".join(repr(float(v)) for v in ref[k]) if ref is not None else ",,"
        rows.append(f"{float(result.stamps[k])!r},{est},{tail}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")


def write_outputs(result: OfflineResult, out_dir: str | Path) -> dict[str, str]:
    """Write the run's products into ``out_dir`` and return ``{what: path}``.

    ``map.yaml`` + ``map.pgm`` (map_server format, Nav2 map_saver trinary thresholds),
    ``map.png`` (probability picture), ``trajectory.csv``, ``map.posegraph`` (reloadable
    session, :mod:`navstack.mapping.slam_io`), ``graph.g2o`` (the optimised pose graph)
    and ``summary.json`` (:func:`summary`).
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OfflineSlamError(f"cannot create the output folder {out} ({exc})") from None
    grid = result.mapper.build_map()
    files = {"map_yaml": out / "map.yaml", "map_image": grid.save(out / "map.yaml"),
             "map_png": grid.save_png(out / "map.png"),
             "trajectory": out / "trajectory.csv",
             "posegraph": save_posegraph(result.mapper, out / "map.posegraph"),
             "g2o": out / "graph.g2o", "summary": out / "summary.json"}
    write_trajectory_csv(result, files["trajectory"])
    write_g2o(result.mapper.graph.to_g2o(), files["g2o"])
    names = {k: str(v) for k, v in files.items()}
    files["summary"].write_text(json.dumps(summary(result, names), indent=2) + "\n",
                                encoding="utf-8")
    return names

"""What an offline SLAM run writes and reports: metrics, ``summary.json``, map and graph
files (:func:`write_outputs`; the run itself is :mod:`navstack.mapping.offline`)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from navstack.mapping.g2o import write_g2o
from navstack.mapping.map_metrics import RelativePoseError, TrajectoryScores
from navstack.mapping.slam_io import save_posegraph

if TYPE_CHECKING:
    from navstack.mapping.offline import OfflineResult

__all__ = ["metrics", "summary", "write_outputs", "write_trajectory_csv"]

#: how many odometry events / recovered scans the summary lists one by one
EVENTS_SHOWN = 10


def _rpe_dict(rpe: RelativePoseError | None) -> dict[str, float | int] | None:
    if rpe is None:
        return None
    return {"trans_mean_m": rpe.trans_mean_m, "trans_std_m": rpe.trans_std_m,
            "rot_mean_deg": rpe.rot_mean_deg, "rot_std_deg": rpe.rot_std_deg,
            "pairs": rpe.pairs}


def _scores_dict(scores: TrajectoryScores | None) -> dict[str, Any] | None:
    if scores is None:
        return None
    loops = scores.loops
    return {
        "ate_m": scores.ate.rms_m, "ate_max_m": scores.ate.max_m,
        "rpe": {str(d): _rpe_dict(r) for d, r in scores.rpe.items()},
        "loop_relations": None if loops is None else {
            "trans_mean_m": loops.trans_mean_m, "trans_max_m": loops.trans_max_m,
            "rot_mean_deg": loops.rot_mean_deg, "pairs": loops.pairs},
    }


def metrics(result: OfflineResult) -> dict[str, float]:
    """The run's numbers under the ``navstack bench slam`` metric names without the log
    prefix: ``trans_err_m``, ``trans_err_std_m``, ``rot_err_deg``, ``rot_err_std_deg``
    (consecutive pairs), ``ate_m`` (aligned), ``rpe10_trans_m``, ``rpe100_trans_m``,
    ``loop_trans_m`` / ``loop_pairs`` (loop relations), ``odometry_ate_m`` (only with a
    reference); ``ms_per_scan`` (median over nodes), ``ms_first_10`` / ``ms_last_10``
    (mean over the first / last tenth of the scans) and their ``ms_growth`` ratio,
    ``speedup`` (only with a log duration), ``scans``, ``nodes``, ``loop_closures``,
    ``odometry_events``, ``recovered_scans`` and ``ambiguous_scans`` (scans without
    odometry over their step placed although the wide search was ambiguous)."""
    stats = result.mapper.stats
    out: dict[str, float] = {"scans": float(result.scans),
                             "nodes": float(len(result.mapper.nodes)),
                             "loop_closures": float(stats.loop_closures),
                             "odometry_events": float(len(stats.odometry_events)),
                             "recovered_scans": float(len(stats.recovered_scans)),
                             "ambiguous_scans": float(len(stats.ambiguous_scans))}
    if result.rpe is not None:
        out.update(trans_err_m=result.rpe.trans_mean_m, trans_err_std_m=result.rpe.trans_std_m,
                   rot_err_deg=result.rpe.rot_mean_deg, rot_err_std_deg=result.rpe.rot_std_deg)
    s = result.scores
    if s is not None:
        out["ate_m"] = s.ate.rms_m
        for d in (10, 100):
            if d in s.rpe:
                out[f"rpe{d}_trans_m"] = s.rpe[d].trans_mean_m
        if s.loops is not None:
            out["loop_trans_m"] = s.loops.trans_mean_m
            out["loop_pairs"] = float(s.loops.pairs)
    if result.odometry_scores is not None:
        out["odometry_ate_m"] = result.odometry_scores.ate.rms_m
    if math.isfinite(result.ms_per_scan):
        out["ms_per_scan"] = result.ms_per_scan
    first, last = result.tenth_ms()
    if math.isfinite(first) and math.isfinite(last):
        out.update(ms_first_10=first, ms_last_10=last,
                   ms_growth=last / first if first > 0 else math.inf)
    if result.speedup is not None:
        out["speedup"] = result.speedup
    return out


def summary(result: OfflineResult, files: Mapping[str, str] | None = None) -> dict[str, Any]:
    """JSON-ready summary of a run (written as ``summary.json`` by :func:`write_outputs`)."""
    from navstack.mapping.offline import LOG_PROFILE, SKIPPED_SHOWN

    stats = result.mapper.stats
    first, last = result.tenth_ms()
    return {
        "metrics": metrics(result),
        "log": str(result.log_path),
        "scans_in_log": result.scans_in_log,
        "scans": result.scans,
        "nodes": len(result.mapper.nodes),
        "loop_closures": stats.loop_closures,
        "loop_attempts": stats.loop_attempts,
        "loop_rejected": {"ambiguous": stats.loop_ambiguous,
                          "implausible": stats.loop_implausible,
                          "weak": stats.loop_weak,
                          "seen_through": stats.loop_seen_through,
                          "window_edge": stats.loop_window_edge,
                          "outliers": stats.loop_rejected_outliers,
                          "unconfirmed": stats.loop_unconfirmed},
        "corridor_closures": stats.loop_corridor,
        "batch_optimizations": stats.batch_optimizations,
        "match_failures": stats.match_failures,
        "odometry": {
            "gaps_in_log": result.odometry_gaps,
            "events": len(stats.odometry_events),
            "first_events": [{"scan": k, "reason": r}
                             for k, r in stats.odometry_events[:EVENTS_SHOWN]],
            "wide_searches": stats.wide_searches,
            "recovered_scans": stats.recovered_scans[:EVENTS_SHOWN],
            "recovered": len(stats.recovered_scans),
            "ambiguous_scans": stats.ambiguous_scans[:EVENTS_SHOWN],
            "ambiguous": len(stats.ambiguous_scans),
            "unlinked_nodes": stats.unlinked_nodes,
            "odometry_edges": stats.odometry_edges,
        },
        "rpe": _rpe_dict(result.rpe),
        "odometry_rpe": _rpe_dict(result.odometry_rpe),
        "scores": _scores_dict(result.scores),
        "odometry_scores": _scores_dict(result.odometry_scores),
        "reference": ("corrected FLASER poses" if result.reference is not None
                      else "none (the log is not an anchored 'corrected' release)"),
        "ms_per_scan": result.ms_per_scan if math.isfinite(result.ms_per_scan) else None,
        "ms_first_10": first if math.isfinite(first) else None,
        "ms_last_10": last if math.isfinite(last) else None,
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
    from navstack.mapping.offline import OfflineSlamError

    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OfflineSlamError(f"cannot create the output folder {out} ({exc})") from None
    grid = result.mapper.build_map()
    files = {"map_yaml": out / "map.yaml",
             "map_image": grid.save(out / "map.yaml",
                                    free_thresh=result.mapper.params.map_free_thresh),
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

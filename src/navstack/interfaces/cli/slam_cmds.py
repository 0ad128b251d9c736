"""``navstack slam``: offline SLAM on a CARMEN log."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, slam_overrides, write_json
from navstack.mapping.map_metrics import TrajectoryScores


@app.command()
def slam(
    carmen: Annotated[Path, typer.Option(help="CARMEN log (plain text or .gz).")],
    out: Annotated[Path, typer.Option(help="Folder for map.yaml/.pgm/.png, trajectory.csv, "
                                      "map.posegraph, graph.g2o and summary.json.")],
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the summary here.")]
    = None,
    params: Annotated[Path | None, typer.Option(
        help="slam_toolbox parameter YAML (slam_toolbox: ros__parameters: ...), applied "
             "over the log profile.")] = None,
    max_scans: Annotated[int | None, typer.Option(min=1, help="Stop after N scans.")] = None,
) -> None:
    """Offline SLAM on a CARMEN log: map, trajectory, pose graph and its errors."""
    from navstack.mapping.offline import Progress, run_carmen, summary, warm_up, write_outputs

    def progress(p: Progress) -> None:
        if p.scans < p.total:  # the final report is the summary below
            typer.echo(f"  {p.scans}/{p.total} scans, {p.nodes} nodes, {p.loop_closures} "
                       f"loop closures, {p.ms_per_scan:.1f} ms/scan", err=True)

    try:
        overrides = slam_overrides(params)
        warm_up()
        result = run_carmen(carmen, overrides, max_scans=max_scans,
                            params_file=str(params) if params is not None else "",
                            progress=progress)
        files = write_outputs(result, out)
    except (NavstackError, OSError) as exc:
        raise fail(str(exc)) from None
    report = summary(result, files)
    skipped = report["skipped_lines"]
    if skipped["count"]:
        shown = "; ".join(f"line {s['line']}: {s['reason']}" for s in skipped["first"])
        more = ", ..." if skipped["count"] > len(skipped["first"]) else ""
        typer.echo(f"warning: {skipped['count']} log line(s) skipped ({shown}{more})", err=True)
    stats = result.mapper.stats
    typer.echo(f"{result.scans} scans processed ({len(result.mapper.nodes)} nodes), "
               f"{stats.loop_closures} loop closures, {stats.match_failures} match failures")
    if result.rpe is not None:
        r = result.rpe
        line = (f"RPE over {r.pairs} consecutive pairs vs the corrected poses: trans "
                f"{r.trans_mean_m:.4f} ± {r.trans_std_m:.4f} m, rot {r.rot_mean_deg:.3f} ± "
                f"{r.rot_std_deg:.3f} deg")
        if result.odometry_rpe is not None:
            o = result.odometry_rpe
            line += f" (odometry alone: {o.trans_mean_m:.4f} m, {o.rot_mean_deg:.3f} deg)"
        typer.echo(line)
    else:
        typer.echo("RPE: not scored (the log has no corrected reference poses)")
    if result.scores is not None:
        typer.echo(_global_line(result.scores, result.odometry_scores))
    odo = report["odometry"]
    typer.echo(f"odometry: {odo['gaps_in_log']} gaps in the log, {odo['events']} scans with "
               f"missing or implausible odometry, {odo['recovered']} placed by the wide "
               "search")
    speed = (f"speedup {result.speedup:.0f}x over the log's {result.log_duration_s:.0f} s"
             if result.speedup is not None and result.log_duration_s is not None
             else "speedup unknown (log timestamps too coarse)")
    first, last = result.tenth_ms()
    tenths = (f", first/last 10% {first:.1f}/{last:.1f} ms/scan"
              if first == first and last == last else "")
    typer.echo(f"{result.ms_per_scan:.1f} ms/scan (median){tenths}, {result.wall_s:.2f} s "
               f"wall, {speed}")
    typer.echo(f"wrote {', '.join(Path(p).name for p in files.values())} to {out}")
    write_json(json_out, report)


def _global_line(scores: TrajectoryScores, odometry: TrajectoryScores | None) -> str:
    """ATE, long-range RPE and loop relations in one line."""
    parts = [f"ATE {scores.ate.rms_m:.4f} m aligned"
             + (f" (odometry alone {odometry.ate.rms_m:.3f} m)" if odometry else "")]
    far = [f"{d} scans {r.trans_mean_m:.4f} m" for d, r in scores.rpe.items() if d > 1]
    if far:
        parts.append("RPE over " + ", ".join(far))
    loops = scores.loops
    parts.append(f"loop relations {loops.trans_mean_m:.4f} m over {loops.pairs} pairs"
                 if loops else "no loop relations (the reference never comes back)")
    return "global: " + ", ".join(parts)

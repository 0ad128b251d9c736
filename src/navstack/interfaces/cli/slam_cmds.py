"""``navstack slam``: offline SLAM on a CARMEN log."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, slam_overrides, warn, write_json
from navstack.interfaces.cli.options import (
    check_out_dir,
    check_out_file,
    number_option,
    prefer,
)
from navstack.interfaces.cli.progress import StageProgress
from navstack.mapping.map_metrics import TrajectoryScores


@app.command()
def slam(
    log: Annotated[Path | None, typer.Argument(
        metavar="LOG", help="CARMEN log (plain text or .gz).", show_default=False)] = None,
    out: Annotated[Path, typer.Option(help="Folder for map.yaml/.pgm/.png, trajectory.csv, "
                                      "map.posegraph, graph.g2o and summary.json.")]
    = Path("runs/slam"),
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the summary here.")]
    = None,
    params: Annotated[Path | None, typer.Option(
        help="slam_toolbox parameter YAML (slam_toolbox: ros__parameters: ...), applied "
             "over the log profile.")] = None,
    max_scans: Annotated[int | None, number_option(
        "--max-scans", help="Stop after N scans.", low=1, high=10**9, integer=True)] = None,
    carmen: Annotated[Path | None, typer.Option(
        "--carmen", hidden=True, help="Deprecated spelling of the LOG argument.")] = None,
) -> None:
    """Offline SLAM on a CARMEN log: map, trajectory, pose graph and its errors.

    Shows progress per stage (read log, mapping, optimise, write outputs) on stderr, and
    while mapping the scans, nodes, loop closures and ms per scan.
    """
    from navstack.mapping.offline import (
        ScanProgress,
        run_carmen,
        summary,
        warm_up,
        write_outputs,
    )

    log = prefer("the LOG argument", log, "--carmen", carmen, warn)
    if log is None:
        raise fail("give the CARMEN log: navstack slam LOG --out FOLDER "
                   "(see 'navstack slam --help')")
    check_out_dir(out, "--out")
    if json_out is not None:
        check_out_file(json_out, "--json")
    try:
        overrides = slam_overrides(params)
        warm_up()
        with StageProgress("slam") as progress:

            def detail(p: ScanProgress) -> None:
                progress.detail(f"{p.scans}/{p.total} scans, {p.nodes} nodes, "
                                f"{p.loop_closures} loop closures, "
                                f"{p.ms_per_scan:.1f} ms/scan")

            result = run_carmen(log, overrides, max_scans=max_scans,
                                params_file=str(params) if params is not None else "",
                                progress=progress, detail=detail)
            progress("write outputs", 0, 1)
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

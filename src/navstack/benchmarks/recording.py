"""``navstack bench recording``: what recording a rosbag2 adds to the demo's wall time.

Runs the flagship demo (``navstack demo``; quick mode: its first goal only) without and
with ``--record``, interleaved in ABBA order so slow drifts of the machine hit both
alike, several times, and reports ``recording_overhead = median(with) /
median(without) - 1`` (budget <= 0.10, issue 7) with the two medians, and the same ratio
of process CPU times (``recording_overhead_cpu``, steadier on a shared machine).  The time is the
demo's own ``wall_time_s`` (stack construction to the end of the last goal, bag closed),
so plotting and report writing are not part of it.  One untimed run first warms caches.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from navstack.benchmarks.common import BenchResult
from navstack.core.errors import NavstackError
from navstack.interfaces.demo import default_waypoints_path, run_demo

QUICK_WAYPOINTS = """\
waypoints:
  - name: Goal_3
    position: {x: 17.0, y: 3.0, z: 0.0}
    orientation: {x: 0.0, y: 0.0, z: -0.7071068, w: 0.7071068}
"""


class RecordingBenchError(NavstackError):
    """A demo run of the benchmark did not succeed (its timing would mean nothing)."""


def _run(folder: Path, waypoints: Path, record: bool) -> tuple[float, float, int, int]:
    """Wall time [s], process CPU time [s], recorded messages and bag bytes of one run."""
    cpu0 = time.process_time()
    report = run_demo(folder, waypoints_file=waypoints, show_progress=False, record=record)
    cpu = time.process_time() - cpu0
    bag = folder / "bag"
    size = sum(p.stat().st_size for p in bag.iterdir()) if record else 0
    if not report["success"]:
        failed = [f"{g['name']}: {g['status']} {g['reason']}" for g in report["goals"]
                  if g["status"] != "SUCCEEDED"]
        raise RecordingBenchError(f"bench recording: a demo run failed ({'; '.join(failed)}, "
                                  f"{report['collisions']} collisions); timings discarded")
    return (float(report["wall_time_s"]), cpu, int(report.get("bag", {}).get("messages", 0)),
            size)


def run(quick: bool, data_dir: Path | None) -> BenchResult:
    result = BenchResult("recording")
    repeats = 3
    with tempfile.TemporaryDirectory(prefix="navstack-bench-recording-") as tmp:
        root = Path(tmp)
        if quick:
            waypoints = root / "waypoints.yaml"
            waypoints.write_text(QUICK_WAYPOINTS)
        else:
            waypoints = default_waypoints_path()
        _run(root / "warmup", waypoints, True)
        walls: dict[bool, list[float]] = {False: [], True: []}
        cpus: dict[bool, list[float]] = {False: [], True: []}
        messages = size = 0
        for i in range(repeats):
            for record in ((False, True) if i % 2 == 0 else (True, False)):
                wall, cpu, n, nbytes = _run(root / f"run{i}_{int(record)}", waypoints, record)
                walls[record].append(wall)
                cpus[record].append(cpu)
                if record:
                    messages, size = n, nbytes
                result.cases.append({"repeat": i, "record": record, "wall_s": round(wall, 3),
                                     "cpu_s": round(cpu, 3), "messages": n})
    without, with_rec = statistics.median(walls[False]), statistics.median(walls[True])
    cpu_without, cpu_with = statistics.median(cpus[False]), statistics.median(cpus[True])
    result.metrics.update(
        recording_overhead=with_rec / without - 1.0, wall_without_s=without,
        wall_with_s=with_rec, recording_overhead_cpu=cpu_with / cpu_without - 1.0,
        bag_messages=float(messages), bag_mb=size / 1e6,
        recorded_msgs_per_wall_s=messages / with_rec)
    result.notes.append(f"{'first goal of the demo' if quick else 'full demo'}, {repeats} "
                        f"interleaved pairs; budget: recording_overhead <= 0.10")
    result.notes.append("recording_overhead_cpu compares the process CPU time of the whole "
                        "run_demo call (plots included): the steadier figure when other "
                        "processes share the machine")
    return result

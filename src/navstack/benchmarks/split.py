"""``navstack bench split``: the robot / base split over Zenoh against the same stack in
one process (issue 21, acceptance 1-3).

Every split run starts ``navstack robot`` and ``navstack base`` as two OS processes on
loopback with the packaged ``split_office.yaml`` and the office waypoints
(:func:`~navstack.interfaces.split_demo.run_split`); the reference is the same stack
file's nodes and parameters in one process on the in-process bus with the same seed
(:func:`~navstack.interfaces.split_nodes.run_in_process`).

1. **Trajectory** (lockstep): the split on lockstep simulated time against the in-process
   run on simulated time.  ``deviation_m``: symmetric Hausdorff distance between the two
   driven paths (budget 0.2 m); goals and collisions of both.
2. **Added latency** (wall clock at ``rate``): scan -> ``/cmd_vel`` latency -- at every
   ``/cmd_vel`` the robot publishes, its clock's reading minus the stamp of the newest
   ``/scan`` before it (:class:`~navstack.interfaces.split_nodes.ScanToCmd`) -- of the split
   (offset 0 run) and of the in-process run on a wall clock; ``added_scan_to_cmd_p99_ms``
   is the difference of the p99s (budget 5 ms).  Also the one-way ``/scan`` robot -> base
   latency.  Real milliseconds (process seconds divided by the clock rate).
3. **Clock offsets** 0, +0.3, -2, +2, +30 s on the robot (wall clock, the threaded NTP
   exchange): the base's estimate and its error (budget 5 ms), goals and collisions.
   With compensation off, ``navstack check --link base --no-compensate`` against a robot
   with each offset: whether it fails naming ``clock:robot`` and the measured offset
   (offset 0 must pass: within tolerance).
4. **Blackout** of 2 s, 20 s after the robot's link opens (wall clock): seconds from the
   blackout's start to a ``/cmd_vel`` that is zero and stays zero until it ends (budget
   0.5 s), how fast the robot was going just before, watchdog stops and resumes, and the
   mission's goals (it must go on without a restart).

Wall-clock figures depend on the machine's load (the 1-minute load average is in the
notes).  ``--quick``: clock rate 2 and offsets 0 and +30 s only.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from navstack.benchmarks.common import BenchResult, Progress
from navstack.interfaces.demo import default_waypoints_path
from navstack.interfaces.split_demo import (
    hausdorff_xy,
    moving_part,
    run_split,
    score,
    time_to_zero,
)
from navstack.interfaces.split_nodes import run_in_process, trajectory_array

OFFSETS_S = (0.0, 0.3, -2.0, 2.0, 30.0)
BLACKOUT = (20.0, 2.0)
DEVIATION_BUDGET_M = 0.2
ADDED_LATENCY_BUDGET_MS = 5.0
OFFSET_BUDGET_MS = 5.0
ZERO_BUDGET_S = 0.5


def split_stack() -> Path:
    return Path(str(resources.files("navstack") / "config" / "split_office.yaml"))


def _ms(samples: list[float], q: float, rate: float) -> float:
    return float(np.percentile(samples, q)) * 1e3 / rate if samples else float("nan")


def _port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def check_without_compensation(stack: Path, offset: float) -> dict[str, Any]:
    """``navstack check --link base --no-compensate`` against a robot whose clock is
    ``offset`` s off: exit code and whether the output names the contract and offset."""
    port = _port()
    tmp = Path(tempfile.mkdtemp(prefix="navstack-check-"))
    local = tmp / "stack.yaml"
    local.write_text(stack.read_text().replace("7447", str(port)))
    cmd = [sys.executable, "-m", "navstack.app"]
    robot = subprocess.Popen([*cmd, "robot", "--stack", str(local), "--clock-offset",
                              str(offset), "--max-seconds", "120", "--keep-running"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        out = subprocess.run([*cmd, "check", "--stack", str(local), "--link", "base",
                              "--no-compensate", "--duration", "1"],
                             capture_output=True, text=True, timeout=180, check=False)
    finally:
        robot.terminate()
        try:
            robot.wait(timeout=10)
        except subprocess.TimeoutExpired:
            robot.kill()
    text = out.stdout + out.stderr
    line = next((ln.strip() for ln in text.splitlines() if "clock:robot" in ln), "")
    found = re.search(r"offset of 'robot' ([+-]?\d+(?:\.\d+)?) ms", text)
    shown_ms = float(found.group(1)) if found else float("nan")
    return {"returncode": out.returncode, "line": line, "offset_shown_ms": shown_ms,
            "names_contract": "clock:robot" in text,
            "names_offset": abs(shown_ms - offset * 1e3) <= OFFSET_BUDGET_MS}


def run(quick: bool, data_dir: Path | None, progress: Progress | None = None) -> BenchResult:
    del data_dir
    stack, wp = split_stack(), default_waypoints_path()
    rate = 2.0 if quick else 1.0
    offsets = (0.0, 30.0) if quick else OFFSETS_S
    stages = 3 + len(offsets) * 2 + 1
    done = [0]

    def stage(name: str) -> None:
        if progress is not None:
            progress(name, done[0], stages)
        done[0] += 1

    res = BenchResult("split")
    m = res.metrics
    load0 = os.getloadavg()[0]

    # 1. trajectory against the same stack in process (lockstep simulated time)
    stage("in-process reference (simulated time)")
    ref = run_in_process(stack, wp)
    stage("split, lockstep")
    robot, base = run_split(stack, wp, lockstep=True, port=_port())
    ref_xy = moving_part(trajectory_array(ref["trajectory"]))[:, 1:3]
    split_xy = moving_part(trajectory_array(robot["trajectory"]))[:, 1:3]
    m["lockstep_deviation_m"] = hausdorff_xy(split_xy, ref_xy)
    m["lockstep_goals_succeeded"] = base["succeeded"]
    m["lockstep_collisions"] = robot["collisions"]
    m["in_process_goals_succeeded"] = ref["succeeded"]
    m["in_process_collisions"] = ref["collisions"]
    m["goals_total"] = len(base["goals"])
    res.cases.append({"case": "lockstep", "goals": f"{base['succeeded']}/{len(base['goals'])}",
                      "collisions": robot["collisions"],
                      "deviation_m": round(m["lockstep_deviation_m"], 4),
                      "goal_times_s": [g["time_s"] for g in base["goals"]],
                      "in_process_goal_times_s": [g["time_s"] for g in ref["goals"]]})

    # 2. + 3. wall clock: the in-process latency baseline, then every offset
    stage(f"in-process reference (wall clock x{rate:g})")
    wall_ref = run_in_process(stack, wp, wall_rate=rate)
    m["in_process_wall_goals_succeeded"] = wall_ref["succeeded"]
    base_p50 = _ms(wall_ref["scan_to_cmd_s"], 50, rate)
    base_p99 = _ms(wall_ref["scan_to_cmd_s"], 99, rate)
    m["in_process_scan_to_cmd_p50_ms"], m["in_process_scan_to_cmd_p99_ms"] = base_p50, base_p99
    worst_offset_ms, offsets_ok = 0.0, True
    for off in offsets:
        stage(f"split, wall clock x{rate:g}, robot clock {off:+g} s")
        robot, base = run_split(stack, wp, rate=rate, offset=off, port=_port())
        fig = score(robot, base, None, off)
        err = fig["offset_error_ms"]
        ok = (base["succeeded"] == len(base["goals"]) and robot["collisions"] == 0
              and err <= OFFSET_BUDGET_MS and base["clock_contract"]["ok"])
        offsets_ok = offsets_ok and ok
        worst_offset_ms = max(worst_offset_ms, err)
        res.cases.append({"case": f"offset {off:+g} s", "goals": fig["goals"],
                          "collisions": robot["collisions"],
                          "offset_estimated_s": round(base["robot_offset_s"], 6),
                          "offset_error_ms": round(err, 3),
                          "clock_contract": fig["clock_contract"], "ok": ok})
        if off == 0.0:
            p50 = _ms(robot["scan_to_cmd_s"], 50, rate)
            p99 = _ms(robot["scan_to_cmd_s"], 99, rate)
            m["split_scan_to_cmd_p50_ms"], m["split_scan_to_cmd_p99_ms"] = p50, p99
            m["added_scan_to_cmd_p50_ms"] = p50 - base_p50
            m["added_scan_to_cmd_p99_ms"] = p99 - base_p99
            scan = base["latency_s"].get("/scan", {})
            m["scan_robot_to_base_p50_ms"] = 1e3 * scan.get("p50", float("nan"))
            m["scan_robot_to_base_p99_ms"] = 1e3 * scan.get("p99", float("nan"))
            m["robot_loop_lateness_p99_ms"] = fig["robot_loop_lateness_p99_ms"] / rate
            m["wall_deviation_from_lockstep_reference_m"] = hausdorff_xy(
                moving_part(trajectory_array(robot["trajectory"]))[:, 1:3], ref_xy)
    m["offsets_all_ok"] = float(offsets_ok)
    m["offset_error_max_ms"] = worst_offset_ms

    checks_ok = True
    for off in offsets:
        stage(f"navstack check --no-compensate, robot clock {off:+g} s")
        c = check_without_compensation(stack, off)
        expect_fail = abs(off) > 0.005
        ok = ((c["returncode"] == 1 and c["names_contract"] and c["names_offset"])
              if expect_fail else c["returncode"] == 0)
        checks_ok = checks_ok and ok
        res.cases.append({"case": f"check --no-compensate {off:+g} s",
                          "exit": c["returncode"], "offset_shown_ms": c["offset_shown_ms"],
                          "line": c["line"][:110], "ok": ok})
    m["check_without_compensation_ok"] = float(checks_ok)

    # 4. blackout
    stage(f"split, wall clock x{rate:g}, {BLACKOUT[1]:g} s blackout at {BLACKOUT[0]:g} s")
    robot, base = run_split(stack, wp, rate=rate, blackout=BLACKOUT, port=_port())
    fig = score(robot, base, None, 0.0, BLACKOUT)
    start = robot["opened_at"] + BLACKOUT[0]
    before = [abs(vx) + abs(wz) for t, vx, wz in robot["cmd_vel"] if start - 1.0 <= t < start]
    m["blackout_time_to_zero_s"] = (fig["blackout_time_to_zero_s"]
                                    if fig["blackout_time_to_zero_s"] is not None
                                    else float("inf"))
    m["blackout_speed_before_m_s"] = max(before, default=0.0)
    m["blackout_goals_succeeded"] = base["succeeded"]
    m["blackout_collisions"] = robot["collisions"]
    m["blackout_watchdog_stops"] = fig["watchdog_stops"]
    m["blackout_watchdog_resumes"] = fig["watchdog_resumes"]
    res.cases.append({"case": "blackout 20:2", "goals": fig["goals"],
                      "collisions": robot["collisions"],
                      "time_to_zero_s": fig["blackout_time_to_zero_s"],
                      "stops": robot["watchdog"]["stops"],
                      "resumes": robot["watchdog"]["resumes"]})
    ttz_check = time_to_zero(robot["cmd_vel"], start, start + BLACKOUT[1])
    res.notes.append(f"blackout window on the robot clock: {start:.3f} .. "
                     f"{start + BLACKOUT[1]:.3f} s; zero from +{ttz_check} s")
    res.notes.append(f"1-min load average {load0:.1f} at start, {os.getloadavg()[0]:.1f} at "
                     f"end, {os.cpu_count()} CPUs; wall-clock rate {rate:g}; "
                     f"finished {time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}")
    res.notes.append(f"budgets: deviation <= {DEVIATION_BUDGET_M} m, added p99 <= "
                     f"{ADDED_LATENCY_BUDGET_MS} ms, offset error <= {OFFSET_BUDGET_MS} ms, "
                     f"zero command <= {ZERO_BUDGET_S} s after the blackout starts")
    res.show_cases = True
    return res

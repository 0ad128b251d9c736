"""``navstack bench split``: the robot / base split over Zenoh against the same stack in
one process (issue 21, acceptance 1-3).

Every split run starts ``navstack robot`` and ``navstack base`` as two OS processes on
loopback with the packaged ``split_office.yaml`` and the office waypoints
(:func:`~navstack.interfaces.split_demo.run_split`); the reference is the same stack
file's nodes and parameters in one process on the in-process bus with the same seed
(:func:`~navstack.interfaces.split_nodes.run_in_process`).

1. **Trajectory and clock offsets** (lockstep): the split on lockstep simulated time with
   the robot's clock 0, +0.3, -2, +2 and +30 s off, against the in-process run on
   simulated time.  ``deviation_m``: symmetric Hausdorff distance between the two driven
   paths (budget 0.2 m, offset 0); goals, collisions, offset error (the barrier's exact
   estimate) and late deliveries of each.
2. **NTP on wall clocks**: ``navstack check --link base`` (1 s) against a robot with each
   offset, with compensation (the offset it shows is the threaded NTP estimate; error
   budget 5 ms) and without (it must fail naming ``clock:robot`` and the measured offset,
   except at offset 0).
3. **Added latency** (wall clock at ``rate``, :func:`measure_latency`): the same stack
   in one process, then split, back to back.  Per command, traced through the chain
   (:class:`~navstack.interfaces.split_nodes.ScanToCmd`): the wall clock at the
   ``/cmd_vel`` that first carries a controller command minus the stamp of the newest
   scan the local costmap had marked when the controller computed it; its
   ``scheduled`` part (timer phases: identical in both runs, the event order being
   deterministic) and ``late`` part (the loop behind schedule).  Printed at p50 / p95 /
   p99 for both runs; ``added_scan_to_cmd_pXX_ms`` is the split's quantile minus the
   in-process one (budget: p99 <= 5 ms), with the 1-minute load average around it.
   Also the one-way ``/scan`` robot -> base latency and the link's own work on the
   robot's loop per exported message.  Real milliseconds (process seconds divided by
   the clock rate).
4. **Blackout** of 2 s, 20 s after the robot's link opens (lockstep, and wall clock unless
   ``--quick``): seconds from the blackout's start to a ``/cmd_vel`` that is zero and stays
   zero until it ends (budget 0.5 s), how fast the robot was going just before, watchdog
   stops and resumes (seconds after the link opened), and the mission's goals (it must go
   on without a restart).

Wall-clock figures depend on the machine's load (the 1-minute load average is in the
notes): a process whose loop runs behind counts its backlog in the latency.
``--quick``: clock rate 2, offsets 0 and +30 s only, no wall-clock blackout.
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
)
from navstack.interfaces.split_nodes import run_in_process, trajectory_array

OFFSETS_S = (0.0, 0.3, -2.0, 2.0, 30.0)
BLACKOUT = (20.0, 2.0)
DEVIATION_BUDGET_M = 0.2
ADDED_LATENCY_BUDGET_MS = 5.0
OFFSET_BUDGET_MS = 5.0
ZERO_BUDGET_S = 0.5
QUANTILES = (50, 95, 99)


def split_stack() -> Path:
    return Path(str(resources.files("navstack") / "config" / "split_office.yaml"))


def _ms(samples: list[float], q: float, rate: float) -> float:
    return float(np.percentile(samples, q)) * 1e3 / rate if samples else float("nan")


def _port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def check_clock(stack: Path, offset: float, compensate: bool = False) -> dict[str, Any]:
    """``navstack check --link base [--no-compensate]`` (1 s on a wall clock) against a
    robot whose clock is ``offset`` s off: exit code, the offset it shows (the threaded
    NTP estimate) and whether the output names the contract and that offset."""
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
                              *([] if compensate else ["--no-compensate"]),
                              "--duration", "1"],
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


def latency_figures(run: dict[str, Any], rate: float, prefix: str) -> dict[str, float]:
    """p50/p95/p99 [real ms] of a run's traced scan -> ``/cmd_vel`` latencies
    (:class:`~navstack.interfaces.split_nodes.ScanToCmd`): the whole latency, its
    scheduled part (timer phases) and its late part (the loop behind its schedule)."""
    out: dict[str, float] = {f"{prefix}_scan_to_cmd_samples": float(len(run["scan_to_cmd_s"]))}
    for key, part in (("scan_to_cmd_s", ""), ("scan_to_cmd_scheduled_s", "_scheduled"),
                      ("scan_to_cmd_late_s", "_late")):
        for q in QUANTILES:
            out[f"{prefix}_scan_to_cmd{part}_p{q}_ms"] = _ms(run[key], q, rate)
    return out


def measure_latency(stack: Path, wp: Path, rate: float, res: BenchResult | None = None
                    ) -> tuple[dict[str, float], tuple[dict[str, Any], dict[str, Any]] | None]:
    """Acceptance 1's added latency: the same stack in one process, then split, both on a
    wall clock at ``rate``, back to back; per quantile, the split's traced scan ->
    ``/cmd_vel`` latency minus the in-process one (module docstring).  Returns the
    figures and the split's reports (``None`` if it failed)."""
    m: dict[str, float] = {"latency_load_1min_start": os.getloadavg()[0]}
    wall_ref = run_in_process(stack, wp, wall_rate=rate)
    m["in_process_wall_goals_succeeded"] = wall_ref["succeeded"]
    m.update(latency_figures(wall_ref, rate, "in_process"))
    got = (_split_case(res, "wall clock", stack, wp, rate=rate) if res is not None
           else run_split(stack, wp, port=_port(), rate=rate))
    m["latency_load_1min_end"] = os.getloadavg()[0]
    if got is None:
        return m, None
    robot, base = got
    m.update(latency_figures(robot, rate, "split"))
    for q in QUANTILES:
        m[f"added_scan_to_cmd_p{q}_ms"] = (m[f"split_scan_to_cmd_p{q}_ms"]
                                          - m[f"in_process_scan_to_cmd_p{q}_ms"])
    m["added_scan_to_cmd_within_budget"] = float(
        m["added_scan_to_cmd_p99_ms"] <= ADDED_LATENCY_BUDGET_MS)
    scan = base["latency_s"].get("/scan", {})
    m["scan_robot_to_base_p50_ms"] = 1e3 * scan.get("p50", float("nan"))
    m["scan_robot_to_base_p99_ms"] = 1e3 * scan.get("p99", float("nan"))
    m["robot_loop_lateness_p99_ms"] = 1e3 * robot["loop_lateness_s"].get(
        "p99", float("nan")) / rate
    work = robot.get("link_loop_work", {})
    if work.get("messages"):
        m["robot_link_work_per_message_us"] = 1e6 * work["seconds"] / work["messages"]
    sent = robot.get("link_send", {})
    if sent.get("puts"):
        m["robot_sender_put_mean_us"] = 1e6 * sent["put_s"] / sent["puts"]
    return m, got


def _split_case(res: BenchResult, name: str, stack: Path, wp: Path,
                **kw: Any) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """One split run; a run that ends without reports is a failed row, not a crash."""
    try:
        return run_split(stack, wp, port=_port(), **kw)
    except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
        res.cases.append({"case": name, "ok": False, "error": str(exc)[:200]})
        return None


def run(quick: bool, data_dir: Path | None, progress: Progress | None = None) -> BenchResult:
    del data_dir
    stack, wp = split_stack(), default_waypoints_path()
    rate = 2.0 if quick else 1.0  # real time: the latency a robot would see
    offsets = (0.0, 30.0) if quick else OFFSETS_S
    stages = 3 + len(offsets) * 3 + (0 if quick else 1)
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
    ref_xy = moving_part(trajectory_array(ref["trajectory"]))[:, 1:3]
    m["in_process_goals_succeeded"] = ref["succeeded"]
    m["in_process_collisions"] = ref["collisions"]
    m["goals_total"] = len(ref["goals"])
    offsets_ok = True
    for off in offsets:
        stage(f"split, lockstep, robot clock {off:+g} s")
        got = _split_case(res, f"lockstep offset {off:+g} s", stack, wp, lockstep=True,
                          offset=off)
        if got is None:
            offsets_ok = False
            continue
        robot, base = got
        dev = hausdorff_xy(moving_part(trajectory_array(robot["trajectory"]))[:, 1:3], ref_xy)
        err = 1e3 * abs(base["robot_offset_s"] - off)
        ok = (base["succeeded"] == len(base["goals"]) and robot["collisions"] == 0
              and err <= OFFSET_BUDGET_MS and base["clock_contract"]["ok"])
        offsets_ok = offsets_ok and ok
        if off == 0.0:
            m["lockstep_deviation_m"] = dev
            m["lockstep_goals_succeeded"] = base["succeeded"]
            m["lockstep_collisions"] = robot["collisions"]
        res.cases.append({"case": f"lockstep offset {off:+g} s",
                          "goals": f"{base['succeeded']}/{len(base['goals'])}",
                          "collisions": robot["collisions"], "deviation_m": round(dev, 4),
                          "offset_error_ms": round(err, 4),
                          "late_deliveries": robot["late_deliveries"]
                          + base["late_deliveries"],
                          "goal_times_s": [g["time_s"] for g in base["goals"]], "ok": ok})
    res.cases.append({"case": "in-process reference", "goals": f"{ref['succeeded']}/"
                      f"{len(ref['goals'])}", "collisions": ref["collisions"],
                      "goal_times_s": [g["time_s"] for g in ref["goals"]]})
    m["lockstep_offsets_all_ok"] = float(offsets_ok)

    # 2. the NTP estimate on wall clocks, with and without compensation
    worst, checks_ok = 0.0, True
    for off in offsets:
        for compensate in (True, False):
            stage(f"navstack check{'' if compensate else ' --no-compensate'}, robot clock "
                  f"{off:+g} s")
            c = check_clock(stack, off, compensate)
            err = abs(c["offset_shown_ms"] - off * 1e3)
            if compensate:
                worst = max(worst, err) if np.isfinite(err) else float("inf")
                ok = c["returncode"] == 0 and err <= OFFSET_BUDGET_MS
            elif abs(off) > 0.005:
                ok = c["returncode"] == 1 and c["names_contract"] and c["names_offset"]
            else:
                ok = c["returncode"] == 0
            checks_ok = checks_ok and ok
            res.cases.append({"case": f"check{'' if compensate else ' --no-compensate'} "
                              f"{off:+g} s", "exit": c["returncode"],
                              "offset_shown_ms": c["offset_shown_ms"],
                              "line": c["line"][:110], "ok": ok})
    m["wall_offset_error_max_ms"] = worst
    m["clock_checks_ok"] = float(checks_ok)

    # 3. added scan -> cmd_vel latency and a wall-clock split
    stage(f"in-process reference and split, wall clock x{rate:g} (latency)")
    lat, got = measure_latency(stack, wp, rate, res)
    m.update(lat)
    if "added_scan_to_cmd_p99_ms" in lat:
        res.notes.append("scan -> /cmd_vel [ms] p50 / p95 / p99: " + "; ".join(
            f"{label} " + " / ".join(f"{lat[f'{key}_p{q}_ms']:.2f}" for q in QUANTILES)
            for label, key in (("in process", "in_process_scan_to_cmd"),
                               ("split", "split_scan_to_cmd"),
                               ("added", "added_scan_to_cmd")))
            + f" (budget: added p99 <= {ADDED_LATENCY_BUDGET_MS:g}); 1-min load "
            f"{lat['latency_load_1min_start']:.1f} -> {lat['latency_load_1min_end']:.1f}")
    if got is not None:
        robot, base = got
        fig = score(robot, base, None, 0.0)
        m["wall_goals_succeeded"] = base["succeeded"]
        m["wall_collisions"] = robot["collisions"]
        res.cases.append({"case": "wall clock", "goals": fig["goals"],
                          "collisions": robot["collisions"],
                          "offset_error_ms": round(fig["offset_error_ms"], 4),
                          "watchdog_stops": len(robot["watchdog"]["stops"])})
    # 4. blackout: lockstep (reproducible) and wall clock
    modes: tuple[tuple[str, dict[str, Any]], ...] = (("lockstep", {"lockstep": True}),)
    if not quick:
        modes += ((f"wall x{rate:g}", {"rate": rate}),)
    for label, kw in modes:
        stage(f"split, {label}, {BLACKOUT[1]:g} s blackout at {BLACKOUT[0]:g} s")
        got = _split_case(res, f"blackout {label}", stack, wp, blackout=BLACKOUT, **kw)
        if got is None:
            continue
        robot, base = got
        fig = score(robot, base, None, 0.0, BLACKOUT)
        start = robot["opened_at"] + BLACKOUT[0]
        before = [abs(vx) + abs(wz) for t, vx, wz in robot["cmd_vel"]
                  if start - 1.0 <= t < start]
        ttz = fig["blackout_time_to_zero_s"]
        key = "lockstep" if "lockstep" in kw else "wall"
        m[f"blackout_{key}_time_to_zero_s"] = float("inf") if ttz is None else ttz / (
            1.0 if "lockstep" in kw else rate)
        m[f"blackout_{key}_goals_succeeded"] = base["succeeded"]
        m[f"blackout_{key}_collisions"] = robot["collisions"]
        res.cases.append({"case": f"blackout {label}", "goals": fig["goals"],
                          "collisions": robot["collisions"], "time_to_zero_s": ttz,
                          "speed_before": round(max(before, default=0.0), 3),
                          "stops": [round(t - robot["opened_at"], 3)
                                    for t in robot["watchdog"]["stops"]],
                          "resumes": [round(t - robot["opened_at"], 3)
                                      for t in robot["watchdog"]["resumes"]],
                          "ok": (ttz is not None and ttz <= ZERO_BUDGET_S
                                 and base["succeeded"] == len(base["goals"])
                                 and robot["collisions"] == 0)})
    res.notes.append(f"1-min load average {load0:.1f} at start, {os.getloadavg()[0]:.1f} at "
                     f"end, {os.cpu_count()} CPUs; wall-clock rate {rate:g} (latencies and "
                     f"wall times in real ms / s); finished "
                     f"{time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}")
    res.notes.append(f"budgets: deviation <= {DEVIATION_BUDGET_M} m, added p99 <= "
                     f"{ADDED_LATENCY_BUDGET_MS} ms, offset error <= {OFFSET_BUDGET_MS} ms, "
                     f"zero command <= {ZERO_BUDGET_S} s after the blackout starts")
    res.show_cases = True
    return res

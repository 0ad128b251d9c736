"""``navstack split-demo``: the office mission as robot + base processes over Zenoh, scored
against the same stack file run in one process with the same seed (issue 21 acceptance
1-3; ``navstack bench split`` runs all cases).

Spawns ``navstack robot`` and ``navstack base`` as two OS processes talking over Zenoh on
loopback, waits for both, and scores: goals reached, collisions, the trajectory's
deviation from the in-process reference (the same stack file's robot and base halves on
one runtime, :func:`~navstack.interfaces.split_nodes.run_in_process`; symmetric Hausdorff
distance between the two
paths in the plane: the farthest any point of one is from the other), latencies, the
base's estimate of the robot's clock offset, and -- with a blackout -- how long after the
blackout began the robot's base command was zero.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path as FsPath
from typing import Any

import numpy as np
from scipy.spatial import cKDTree


def hausdorff_xy(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Hausdorff distance [m] between two ``(N, 2)`` point paths."""
    if len(a) == 0 or len(b) == 0:
        return float("inf")
    d_ab = cKDTree(b).query(a)[0].max()
    d_ba = cKDTree(a).query(b)[0].max()
    return float(max(d_ab, d_ba))


def moving_part(traj: np.ndarray, eps: float = 0.01) -> np.ndarray:
    """Rows ``(t, x, y, ...)`` from the first to the last that moved (idle ends cut)."""
    if len(traj) < 2:
        return traj
    step = np.hypot(*np.diff(traj[:, 1:3], axis=0).T)
    moved = np.nonzero(step > eps)[0]
    return traj if moved.size == 0 else traj[moved[0]:moved[-1] + 2]


def time_to_zero(cmds: Sequence[Sequence[float]], start: float, end: float) -> float | None:
    """Seconds from ``start`` until ``/cmd_vel`` was zero and stayed zero until ``end``
    (``None``: never within the window)."""
    window = [(t, vx, wz) for t, vx, wz in cmds if start <= t < end]
    zero_from = None
    for t, vx, wz in window:
        zero_from = (t if zero_from is None else zero_from) if vx == 0.0 and wz == 0.0 else None
    return None if zero_from is None else zero_from - start


def _cmd(role: str, stack: FsPath, out: FsPath, args: Sequence[str]) -> list[str]:
    return [sys.executable, "-m", "navstack.app", role, "--stack", str(stack),
            "--report", str(out), *args]


def run_split(stack: FsPath, waypoints: FsPath, *, rate: float = 2.0, offset: float = 0.0,
              compensate: bool = True, blackout: tuple[float, float] | None = None,
              port: int = 7447, timeout_s: float = 1800.0,
              lockstep: bool = False) -> tuple[dict[str, Any], dict[str, Any]]:
    """Run robot and base as two processes; returns their reports."""
    tmp = FsPath(tempfile.mkdtemp(prefix="navstack-split-"))
    common = ["--lockstep"] if lockstep else ["--rate", str(rate)]
    robot_args = [*common, "--listen", f"tcp/127.0.0.1:{port}", "--clock-offset", str(offset)]
    if blackout is not None:
        robot_args += ["--blackout", f"{blackout[0]}:{blackout[1]}"]
    base_args = [*common, "--connect", f"tcp/127.0.0.1:{port}", "--waypoints", str(waypoints)]
    if not compensate:
        base_args.append("--no-compensate")
        robot_args.append("--no-compensate")
    env = dict(os.environ)
    robot = subprocess.Popen(_cmd("robot", stack, tmp / "robot.json", robot_args), env=env)
    try:
        base = subprocess.run(_cmd("base", stack, tmp / "base.json", base_args), env=env,
                              timeout=timeout_s, check=False)
        robot.wait(timeout=60)
    finally:
        if robot.poll() is None:
            robot.terminate()
            robot.wait(timeout=10)
    if not (tmp / "base.json").exists():  # (it exits 1 with a report when a goal fails)
        raise RuntimeError(f"navstack base exited with {base.returncode} (see its output)")
    if not (tmp / "robot.json").exists():
        raise RuntimeError(f"navstack robot exited with {robot.returncode} (see its output)")
    return (json.loads((tmp / "robot.json").read_text()),
            json.loads((tmp / "base.json").read_text()))


def _pct_ms(samples: Sequence[float], q: float, rate: float) -> float:
    """Percentile ``q`` of process-clock seconds in real milliseconds."""
    return float(np.percentile(samples, q)) * 1e3 / rate if len(samples) else float("nan")


def score(robot: dict[str, Any], base: dict[str, Any], reference: np.ndarray | None,
          offset: float = 0.0, blackout: tuple[float, float] | None = None) -> dict[str, Any]:
    """The acceptance figures of one split run (module docstring)."""
    traj = np.asarray(robot["trajectory"], dtype=float).reshape(-1, 4)
    goals = base["goals"]
    scan = base["latency_s"].get("/scan", {})
    out: dict[str, Any] = {
        "goals": f"{base['succeeded']}/{len(goals)}",
        "goals_succeeded": base["succeeded"], "goals_total": len(goals),
        "collisions": robot["collisions"],
        "scan_to_base_latency_p50_ms": 1e3 * scan.get("p50", float("nan")),
        "scan_to_base_latency_p99_ms": 1e3 * scan.get("p99", float("nan")),
        **{f"scan_to_cmd_vel_p{q}_ms": _pct_ms(robot.get("scan_to_cmd_s", []), q,
                                               robot.get("clock_rate", 1.0))
           for q in (50, 95, 99)},
        "robot_loop_lateness_p99_ms": 1e3 * robot["loop_lateness_s"].get("p99", float("nan")),
        "goal_round_trip_p99_ms": 1e3 * base["goal_round_trip_s"].get("p99", float("nan")),
        "offset_configured_s": offset,
        "offset_estimated_s": base["robot_offset_s"],
        "offset_error_ms": 1e3 * abs(base["robot_offset_s"] - offset),
        "clock_contract": ("ok" if base["clock_contract"]["ok"] else "FAIL: ")
        + ("" if base["clock_contract"]["ok"] else base["clock_contract"]["detail"]),
    }
    if reference is not None:
        out["trajectory_deviation_m"] = hausdorff_xy(moving_part(traj)[:, 1:3],
                                                     moving_part(reference)[:, 1:3])
    if blackout is not None:
        start = robot["opened_at"] + blackout[0]
        ttz = time_to_zero(robot["cmd_vel"], start, start + blackout[1])
        out["blackout_time_to_zero_s"] = ttz
        out["watchdog_stops"] = len(robot["watchdog"]["stops"])
        out["watchdog_resumes"] = len(robot["watchdog"]["resumes"])
    return out


def reference_run(stack: FsPath, waypoints: FsPath, wall_rate: float | None = None,
                  clock_offset: float = 0.0) -> dict[str, Any]:
    """The same stack file's split run in one process with the in-process bus and the
    same seed (:func:`~navstack.interfaces.split_nodes.run_in_process`)."""
    from navstack.interfaces.split_nodes import run_in_process

    return run_in_process(stack, waypoints, wall_rate=wall_rate, clock_offset=clock_offset)

"""Robot and base as two OS processes over Zenoh on loopback (issue 21): a goal through
the split stack with the robot's clock 30 s ahead, and the clock contract of
``navstack check --link``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.integration.split_mission import ONE_GOAL, STACK
from tests.runtime.zenoh_helpers import free_port


def _navstack(*args: str) -> list[str]:
    return [sys.executable, "-m", "navstack.app", *args]


def test_goal_through_the_split_with_the_robot_clock_30_s_ahead(tmp_path: Path) -> None:
    port = free_port()
    wp = tmp_path / "wp.yaml"
    wp.write_text(ONE_GOAL)
    env = dict(os.environ)
    robot = subprocess.Popen(_navstack(
        "robot", "--stack", str(STACK), "--listen", f"tcp/127.0.0.1:{port}", "--rate", "2",
        "--clock-offset", "30", "--report", str(tmp_path / "robot.json")), env=env,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        base = subprocess.run(_navstack(
            "base", "--stack", str(STACK), "--connect", f"tcp/127.0.0.1:{port}", "--rate", "2",
            "--waypoints", str(wp), "--goal-timeout", "60",
            "--report", str(tmp_path / "base.json")), env=env, capture_output=True, text=True,
            timeout=180)
        robot_out, _ = robot.communicate(timeout=60)
    finally:
        if robot.poll() is None:
            robot.kill()
    assert base.returncode == 0, base.stdout + base.stderr
    rep_b = json.loads((tmp_path / "base.json").read_text())
    rep_r = json.loads((tmp_path / "robot.json").read_text())
    assert rep_b["goals"][0]["status"] == "SUCCEEDED"
    assert rep_r["collisions"] == 0
    assert abs(rep_b["robot_offset_s"] - 30.0) < 0.005  # estimated within 5 ms
    assert abs(rep_r["base_offset_s"] + 30.0) < 0.005
    assert rep_b["clock_contract"]["ok"]  # 30 s off, but compensated
    # the robot really drove to the goal (its true trajectory ends near it)
    x, y = rep_r["trajectory"][-1][1:3]
    assert ((x - 2.5) ** 2 + (y - 4.0) ** 2) ** 0.5 < 0.5
    assert "[robot] done: 0 collisions" in robot_out


def test_check_names_the_clock_contract_and_the_offset(tmp_path: Path) -> None:
    port = free_port()
    stack = tmp_path / "stack.yaml"
    stack.write_text(STACK.read_text().replace("7447", str(port)))
    robot = subprocess.Popen(_navstack(
        "robot", "--stack", str(stack), "--clock-offset", "2.0", "--max-seconds", "90",
        "--keep-running"),
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # a wide terminal: rich wraps the table's cells at 80 columns without a tty, and a
    # wrapped "compensation is off" no longer matches
    wide = dict(os.environ, COLUMNS="250")
    try:
        bad = subprocess.run(_navstack("check", "--stack", str(stack), "--link", "base",
                                       "--no-compensate", "--duration", "1"),
                             capture_output=True, text=True, timeout=120, env=wide)
        good = subprocess.run(_navstack("check", "--stack", str(stack), "--link", "base",
                                        "--duration", "1"),
                              capture_output=True, text=True, timeout=120, env=wide)
    finally:
        robot.kill()
        robot.wait(timeout=10)
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert "failed: clock:robot" in bad.stdout
    assert "+2000." in bad.stdout and "compensation is off" in bad.stdout
    assert good.returncode == 0, good.stdout + good.stderr
    assert "compensated on receipt" in good.stdout


def test_lockstep_split_matches_the_same_stack_in_one_process(tmp_path: Path) -> None:
    """Lockstep delivers every message at a time its sender's stamp fixes, so the split
    drives the in-process run's route (issue 21 acceptance 1, on one goal)."""
    from navstack.interfaces.split_demo import hausdorff_xy, moving_part, run_split
    from navstack.interfaces.split_nodes import run_in_process, trajectory_array

    wp = tmp_path / "wp.yaml"
    wp.write_text(ONE_GOAL)
    ref = run_in_process(STACK, wp)
    robot, base = run_split(STACK, wp, lockstep=True, port=free_port(), timeout_s=300)
    assert ref["goals"][0]["status"] == base["goals"][0]["status"] == "SUCCEEDED"
    assert ref["collisions"] == robot["collisions"] == 0
    assert robot["late_deliveries"] == base["late_deliveries"] == 0
    assert abs(base["goals"][0]["time_s"] - ref["goals"][0]["time_s"]) <= 0.2
    dev = hausdorff_xy(moving_part(trajectory_array(robot["trajectory"]))[:, 1:3],
                       moving_part(trajectory_array(ref["trajectory"]))[:, 1:3])
    assert dev < 0.05
    # only the link watchdog, last in the robot's chain after the smoother, collision
    # monitor and twist_mux, publishes /cmd_vel
    assert any(vx > 0.1 for _, vx, _ in robot["cmd_vel"])
    assert robot["lockstep"] and base["lockstep"]
    # the robot's scan -> /cmd_vel path is all on the robot: on lockstep time its
    # traced latency is the in-process run's timer phases (ScanToCmd), none late
    assert sorted({round(x, 6) for x in robot["scan_to_cmd_s"]}) == \
        sorted({round(x, 6) for x in ref["scan_to_cmd_s"]}) == [0.101, 0.151, 0.201]
    assert set(robot["scan_to_cmd_late_s"]) == {0.0}
    assert abs(base["robot_offset_s"]) < 1e-9  # lockstep: the barrier's exact estimate

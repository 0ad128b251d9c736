"""Scenario sweeps: serial, local processes and a local Ray cluster of 2 agree exactly."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from navstack.benchmarks.navigation import Outcome, Scenario, chaos_suite
from navstack.benchmarks.sweep import Job, SweepError, run_jobs
from navstack.core.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]


def _short_jobs(count: int) -> list[Job]:
    """The ``count`` shortest trips of a small chaos draw (faults that act mid-run)."""
    pool = chaos_suite(12, seed=7, faults="kidnap,scan_latency,tf_delay")
    pool.sort(key=lambda s: math.hypot(s.goal.x - s.start.x, s.goal.y - s.start.y))
    return [Job(sc, i) for i, sc in enumerate(pool[:count])]


@pytest.fixture(scope="module")
def jobs() -> list[Job]:
    return _short_jobs(3)


@pytest.fixture(scope="module")
def serial(jobs: list[Job]) -> list[Outcome]:
    seen: list[tuple[int, int]] = []
    out = run_jobs(jobs, "serial", progress=lambda stage, done, total: seen.append(
        (done, total)))
    assert seen == [(0, 3), (1, 3), (2, 3), (3, 3)]
    return out


def test_serial_runs_succeed_without_collisions(serial: list[Outcome]) -> None:
    assert [o.status for o in serial] == ["SUCCEEDED"] * 3
    assert all(o.collisions == 0 and o.final_dist_m < 0.3 for o in serial)
    assert len({o.scenario.fault.kind for o in serial if o.scenario.fault}) >= 1


def test_local_processes_match_serial_exactly(jobs: list[Job], serial: list[Outcome]) -> None:
    local = run_jobs(jobs, "local", workers=2)
    assert [o.result_key() for o in local] == [o.result_key() for o in serial]


_RAY_CHILD = """
import json
from navstack.benchmarks.sweep import run_jobs
from tests.benchmarks.test_sweep import _short_jobs
done = []
out = run_jobs(_short_jobs(3), "ray", workers=2,
               progress=lambda stage, d, total: done.append(d))
print(json.dumps({"keys": [list(o.result_key()) for o in out], "done": done}))
"""


def test_ray_cluster_of_two_matches_serial_exactly(serial: list[Outcome]) -> None:
    """In a child process: a Ray driver installs its own SIGTERM handler and background
    threads, which must not outlive this test in the pytest process."""
    pytest.importorskip("ray")
    res = subprocess.run([sys.executable, "-c", _RAY_CHILD], cwd=ROOT, capture_output=True,
                         text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stderr[-3000:]
    data = json.loads(res.stdout.strip().splitlines()[-1])
    want = [json.loads(json.dumps(list(o.result_key()))) for o in serial]
    assert data["keys"] == want
    done = data["done"]
    assert done[0] == 0 and done[-1] == 3 and done == sorted(done)


def test_lean_head_skips_three_services_only_while_the_cluster_starts() -> None:
    from types import SimpleNamespace

    from navstack.benchmarks.sweep_ray import LEAN_SKIPPED, _lean_head

    class Node:
        def start_log_monitor(self) -> str:
            return "log monitor"

        def start_monitor(self) -> str:
            return "autoscaler"

        def start_api_server(self, **kwargs: object) -> str:
            return "api server"

    fake_ray = SimpleNamespace(_private=SimpleNamespace(node=SimpleNamespace(Node=Node)))
    with _lean_head(fake_ray):
        assert [getattr(Node(), name)() for name in LEAN_SKIPPED] == [None] * 3
    assert [getattr(Node(), name)() for name in LEAN_SKIPPED] == [
        "log monitor", "autoscaler", "api server"]
    del Node.start_api_server  # a Ray without one of them: nothing is skipped
    with _lean_head(fake_ray):
        assert Node().start_monitor() == "autoscaler"


def test_bad_executor_options_are_named() -> None:
    with pytest.raises(ConfigError, match="unknown executor 'dask'"):
        run_jobs([], "dask")
    with pytest.raises(ConfigError, match="--address is the Ray cluster's address"):
        run_jobs([], "local", address="auto")
    with pytest.raises(ConfigError, match="--workers must be >= 1"):
        run_jobs([], "ray", workers=0)


def test_unreachable_ray_address_is_a_sweep_error(jobs: list[Job]) -> None:
    pytest.importorskip("ray")
    with pytest.raises(SweepError, match=r"no Ray cluster answers at 127\.0\.0\.1:1 "):
        run_jobs(jobs[:1], "ray", address="127.0.0.1:1")
    with pytest.raises(SweepError, match=r"at ray://127\.0\.0\.1:1 "):
        run_jobs(jobs[:1], "ray", address="ray://127.0.0.1:1")


def test_cli_sweep_writes_report(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from navstack.app import app

    out = tmp_path / "rep"
    res = CliRunner().invoke(app, ["bench", "navigation", "--scenarios", "1", "--faults",
                                   "none", "--executor", "local", "--workers", "1",
                                   "--report", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads((out / "sweep.json").read_text())
    assert data["metrics"]["scenarios"] == 1.0
    assert data["cases"][0]["name"] == "chaos_0000_office_nominal"
    md = (out / "sweep.md").read_text()
    assert "| nominal | 1 |" in md
    assert (out / "time_to_goal.png").stat().st_size > 1000


def test_report_lists_every_failure_with_its_reason(tmp_path: Path) -> None:
    from navstack.benchmarks.common import BenchResult
    from navstack.benchmarks.sweep_report import chaos_metrics, markdown
    from navstack.core.msgs import Pose2D

    sc = Scenario("t", "office", Pose2D(0, 0, 0), Pose2D(1, 0, 0), "chaos")
    ok = Outcome(sc, "SUCCEEDED", sim_time_s=12.0, final_dist_m=0.1)
    late = Outcome(Scenario("late", "office", Pose2D(0, 0, 0), Pose2D(1, 0, 0)), "TIMEOUT",
                   "timed out after 120 s")
    hit = Outcome(Scenario("hit", "office", Pose2D(0, 0, 0), Pose2D(1, 0, 0)), "SUCCEEDED",
                  collisions=1, min_static_m=0.31, min_moving_m=0.0)
    mute = Outcome(Scenario("mute", "office", Pose2D(0, 0, 0), Pose2D(1, 0, 0)), "FAILED")
    stuck = Outcome(Scenario("stuck", "office", Pose2D(0, 0, 0), Pose2D(1, 0, 0)), "FAILED",
                    "could not reach the goal after 6 recoveries: FollowPath failed: made no "
                    "progress toward the goal: the distance went from 9.34 m to 9.34 m")
    outs = [ok, late, hit, mute, stuck]
    m = chaos_metrics(outs)
    assert m["failures"] == 4.0 and m["failures_without_reason"] == 1.0  # "mute"
    assert m["success_rate_nominal"] == 0.2
    res = BenchResult("navigation-sweep", {"success_rate": 0.25, "collisions": 1.0,
                                           "real_time_factor": 20.0})
    md = markdown(res, outs)
    assert "| timeout | 1 |" in md and "| collision | 1 |" in md
    assert "| FAILED without a reason | 1 |" in md
    assert "| failed: FollowPath failed: made no progress toward the goal | 1 |" in md
    assert "| late | nominal | TIMEOUT | timed out after 120 s |" in md
    assert "| mute | nominal | FAILED | (no reason given) |" in md
    assert ("| hit | nominal | SUCCEEDED | 1 collision (closest approach: static 0.31 m, "
            "moving 0.00 m) |") in md

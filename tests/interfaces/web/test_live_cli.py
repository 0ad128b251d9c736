"""Viewers on a simulation the caller steps (``navstack demo --web``) and ``navstack run``."""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable
from pathlib import Path

import httpx
import yaml
from typer.testing import CliRunner

from navstack.app import app
from navstack.interfaces.demo import run_demo
from navstack.interfaces.live_cli import LiveOptions, attach_to_demo, close_viewers, open_viewers
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack

TOKEN = "test-token-0123456789"


def test_caller_driven_runner_runs_commands_and_observers_in_the_stepping_thread() -> None:
    stack = NavStack("office", "diff_drive", seed=1)
    runner = LiveRunner(stack, real_time_factor=None)
    ticks: list[float] = []
    runner.add_observer(ticks.append)
    runner.start_in_caller()
    seen: list[str] = []

    def client() -> None:  # another thread (a web handler) asks for work
        seen.append(runner.call(lambda s: threading.current_thread().name, timeout=20.0))

    worker = threading.Thread(target=client)
    worker.start()
    while worker.is_alive():
        stack.run_for(0.05)
    worker.join()
    stack.run_for(1.0)
    runner.stop()
    assert seen == [threading.current_thread().name]
    # one observer call per 0.05 s step of simulated time
    assert len(ticks) >= 20
    assert all(abs(b - a - 0.05) < 1e-6 for a, b in itertools.pairwise(ticks))


def test_demo_serves_the_dashboard_while_its_mission_runs(tmp_path: Path) -> None:
    waypoints = tmp_path / "wp.yaml"
    waypoints.write_text(yaml.safe_dump({"waypoints": [
        {"name": "Near", "position": {"x": 2.5, "y": 7.5, "z": 0.0},
         "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}]}))
    codes: list[int] = []
    options = LiveOptions(web=True, port=0, token=TOKEN, real_time_factor=None)

    def attach(stack: NavStack) -> Callable[[], None]:
        runner = LiveRunner(stack, real_time_factor=None)
        handles = open_viewers(runner, options)
        runner.start_in_caller()
        poller = threading.Thread(target=lambda: codes.append(
            httpx.get(f"{handles[0].url}api/state", timeout=20.0).status_code))
        poller.start()  # answered from the demo's own stepping

        def detach() -> None:
            poller.join()
            close_viewers(handles)
            runner.stop()

        return detach

    report = run_demo(tmp_path / "out", seed=1, waypoints_file=waypoints,
                      show_progress=False, attach=attach)
    assert report["success"], report
    assert codes == [200]


def test_attach_to_demo_hook_detaches_cleanly() -> None:
    stack = NavStack("office", "diff_drive", seed=1)
    detach = attach_to_demo(LiveOptions(web=True, port=0, token=TOKEN,
                                        real_time_factor=None))(stack)
    stack.run_for(0.5)
    detach()
    stack.run_for(0.5)  # the runner's tick is inert once stopped


def test_run_without_a_viewer_is_refused() -> None:
    result = CliRunner().invoke(app, ["run", "--duration", "1"])
    assert result.exit_code == 2
    assert "error: nothing to watch: add --web and/or --foxglove" in result.output

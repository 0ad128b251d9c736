"""The real ``navstack`` process: SIGTERM closes a recording like Ctrl-C, and long
commands report progress (a line per stage when stderr is not a terminal)."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from typer.testing import CliRunner

from navstack.app import app
from navstack.interfaces.cli.progress import StageProgress
from navstack.runtime.recording import BagReader


def test_sigterm_finalises_the_demo_recording(tmp_path: Path) -> None:
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "navstack.app", "demo", "--record",
                             "--out", str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + 120.0
        while not list((out / "bag").glob("*.mcap")) and time.monotonic() < deadline:
            time.sleep(0.2)
        time.sleep(3.0)  # the mission is under way, messages are being written
        proc.send_signal(signal.SIGTERM)
        _, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, stderr
    assert "stopped by SIGTERM" in stderr and "Traceback" not in stderr
    with BagReader(out / "bag") as bag:  # closed properly: summary, footer, metadata.yaml
        topics = bag.topics()
        assert topics["/ground_truth"].count > 50 and topics["/scan"].count > 10
        assert bag.end_time > 1.0


def test_stage_progress_is_one_line_per_stage_off_a_terminal() -> None:
    stream = io.StringIO()
    with StageProgress("job", stream=stream, tty=False) as progress:
        for k in range(0, 101, 10):
            progress("mapping", k, 100)
        progress("optimise", 0, 1)
        progress("optimise", 1, 1)
    lines = stream.getvalue().splitlines()
    assert [ln.split(" in ")[0] for ln in lines] == ["job: mapping 100/100", "job: optimise"]
    assert all(ln.endswith(" s") for ln in lines)


def test_stage_progress_on_a_terminal_draws_a_bar_not_lines() -> None:
    stream = io.StringIO()
    with StageProgress("job", stream=stream, tty=True) as progress:
        progress("mapping", 50, 100)
        progress("mapping", 100, 100)
    assert "job: mapping 100/100 in" not in stream.getvalue()
    assert progress.lines[0].startswith("job: mapping 100/100 in")


def test_bench_reports_its_stages(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["bench", "costmap", "--quick", "--json",
                                   str(tmp_path / "c.json")])
    assert res.exit_code == 0, res.output
    assert [ln.split(" in ")[0] for ln in res.stderr.splitlines()] == ["bench costmap: costmap"]
    assert (tmp_path / "c.json").is_file()

"""A user's mission in one Python file: the example of docs/missions.md, run by
``navstack mission FILE`` exactly as printed there; and the command line's errors."""

from __future__ import annotations

import json
import re
from pathlib import Path

from typer.testing import CliRunner

from navstack.app import app

ROOT = Path(__file__).resolve().parents[2]


def docs_example() -> str:
    text = (ROOT / "docs" / "missions.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    example = [b for b in blocks if "def build(ctx" in b]
    assert len(example) == 1, "docs/missions.md must hold one mission-file example"
    return example[0]


def test_the_documented_user_mission_runs_from_its_file(tmp_path: Path) -> None:
    mission = tmp_path / "patrol.py"
    mission.write_text(docs_example())
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["mission", str(mission), "--robot", "diff_drive",
                                   "--out", str(out), "--seed", "2"])
    assert res.exit_code == 0, res.output
    assert res.output.startswith("SUCCESS: SUCCEEDED")
    report = json.loads((out / "report.json").read_text())
    assert report["mission"] == "patrol" and report["world"] == "office"
    assert report["localization"] == "perfect"
    assert report["collisions"] == 0 and report["home_distance_m"] <= 0.3
    events = [text for _, text in report["events"]]
    assert any(t.startswith("Corridor: navigating to (5.00, 7.50") for t in events)
    assert (out / "report.md").is_file() and (out / "trajectory.png").stat().st_size > 1000


def test_mission_command_errors_are_one_line(tmp_path: Path) -> None:
    runner = CliRunner()
    res = runner.invoke(app, ["mission", "explorr"])
    assert res.exit_code == 2
    assert "error: unknown mission 'explorr' (did you mean 'explore'?)" in res.output
    res = runner.invoke(app, ["mission", "explore", "--strategy", "greedy"])
    assert res.exit_code == 2 and "--strategy 'greedy': choose explore_lite" in res.output
    res = runner.invoke(app, ["mission", "coverage", "--target", "1;2"])
    assert res.exit_code == 2 and "--target '1;2' must be two numbers 'x,y'" in res.output
    bad = tmp_path / "bad.py"
    bad.write_text("X = 1\n")
    res = runner.invoke(app, ["mission", str(bad)])
    assert res.exit_code == 2
    assert "a mission file must define build(ctx) -> Mission" in res.output
    res = runner.invoke(app, ["mission", str(tmp_path / "missing.py")])
    assert res.exit_code == 2 and "mission file not found" in res.output

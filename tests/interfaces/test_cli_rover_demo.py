"""``navstack demo --robot rover``'s option checks (the run itself:
tests/integration/test_rover_demo.py)."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from navstack.app import app

runner = CliRunner()


def test_rover_mission_demo_refuses_options_it_cannot_honour(tmp_path: Path) -> None:
    r = runner.invoke(app, ["demo", "--course", str(tmp_path / "c.yaml"),
                            "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "--course is for --robot rover's mission" in r.output
    r = runner.invoke(app, ["demo", "--robot", "rover", "--record",
                            "--out", str(tmp_path / "o2")])
    assert r.exit_code == 2 and "not available for the rover mission" in r.output
    bad = tmp_path / "bad_course.yaml"
    bad.write_text("world: mars_yard\nlegs: []\ndemo: {start: {x: 1, y: 1}, legs: [nope]}\n")
    r = runner.invoke(app, ["demo", "--robot", "rover", "--course", str(bad),
                            "--out", str(tmp_path / "o3")])
    assert r.exit_code == 2 and "demo.legs" in r.output and "nope" in r.output

"""CLI: open-loop sim report, and one-line errors (exit code 2, no traceback)."""

import json
from pathlib import Path

from typer.testing import CliRunner

from navstack.app import app

runner = CliRunner()


def test_sim_reports_pose_collisions_and_rtf(tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    res = runner.invoke(app, ["sim", "--world", "office", "--duration", "4", "--cmd", "0.2,0",
                              "--seed", "2", "--json", str(out)])
    assert res.exit_code == 0, res.output
    rep = json.loads(out.read_text())
    assert rep["collisions"] == 0
    assert abs(rep["final_pose"]["x"] - (1.0 + 0.2 * 4)) < 0.1  # spawn x=1.0, v=0.2 m/s
    assert rep["real_time_factor"] > 1.0
    assert rep["scans"] == 40


def test_unknown_world_is_one_line() -> None:
    res = runner.invoke(app, ["sim", "--world", "ofice"])
    assert res.exit_code == 2
    assert "Traceback" not in res.output
    assert "error: unknown world 'ofice' (did you mean 'office'?)" in res.output


def test_unknown_robot_is_one_line() -> None:
    res = runner.invoke(app, ["sim", "--robot", "turtlebott"])
    assert res.exit_code == 2
    assert "error: unknown robot 'turtlebott' (did you mean 'turtlebot'?)" in res.output


def test_missing_map_file(tmp_path: Path) -> None:
    yaml = tmp_path / "m.yaml"
    yaml.write_text("image: nothere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.25\nnegate: 0\n")
    res = runner.invoke(app, ["sim", "--world", str(yaml)])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "nothere.pgm" in lines[0]


def test_corrupt_map_image(tmp_path: Path) -> None:
    (tmp_path / "bad.pgm").write_bytes(b"P5\n10 10\n255\n\x00\x01")  # truncated pixels
    yaml = tmp_path / "m.yaml"
    yaml.write_text("image: bad.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.25\nnegate: 0\n")
    res = runner.invoke(app, ["sim", "--world", str(yaml)])
    assert res.exit_code == 2
    assert "Traceback" not in res.output and "bad.pgm" in res.output


def test_bad_cmd_value() -> None:
    res = runner.invoke(app, ["sim", "--cmd", "fast"])
    assert res.exit_code == 2
    assert res.output == ("error: --cmd 'fast' must be two numbers 'vx,wz' [m/s, rad/s] "
                          "(e.g. 0.3,0.2)\n")


def test_every_subcommand_has_help() -> None:
    for cmd in (["--help"], ["sim", "--help"], ["worlds", "--help"], ["bench", "--help"],
                ["robots", "--help"], ["-h"], ["sim", "-h"], ["bag", "recover", "-h"]):
        res = runner.invoke(app, cmd)
        assert res.exit_code == 0 and "Usage" in res.output


def test_version_and_help_shows_bracketed_units() -> None:
    from navstack import __version__

    for flag in ("--version", "-V"):
        res = runner.invoke(app, [flag])
        assert (res.exit_code, res.output) == (0, f"navstack {__version__}\n")
    res = runner.invoke(app, ["sim", "-h"], terminal_width=200)
    assert "Constant command 'vx,wz' [m/s, rad/s], within the robot's velocity limits." \
        in res.output
    assert "Simulated seconds to run. Range (0, 3600] s." in res.output

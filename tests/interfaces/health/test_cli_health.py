"""``navstack check`` and ``navstack doctor`` from the command line: tables, exit codes,
one-line errors."""

from __future__ import annotations

from pathlib import Path

import yaml
from typer.testing import CliRunner

from navstack.app import app
from navstack.interfaces.stack import default_nav2_params_path

runner = CliRunner()


def _stack(folder: Path, navigation: str = "") -> Path:
    path = folder / "stack.yaml"
    path.write_text("name: lab\nseed: 3\nrobot: diff_drive\n"
                    "world: {name: office, spawn: [2.0, 7.5, 0.0]}\n"
                    + (f"navigation: {navigation}\n" if navigation else ""))
    return path


def test_check_good_stack_file_passes(tmp_path: Path) -> None:
    res = runner.invoke(app, ["check", "--stack", str(_stack(tmp_path)), "--duration", "3"])
    assert res.exit_code == 0, res.output
    assert "14/14 checks passed\n" in res.output
    for name in ("rate:/scan", "tf", "lifecycle", "cmd_vel_published", "progress"):
        assert name in res.output
    assert "FAIL" not in res.output


def test_check_stack_with_a_wrong_cmd_vel_topic_is_a_config_error(tmp_path: Path) -> None:
    # the controller publishes on a topic nobody relays to the base: a classic remap error,
    # refused when the command chain is resolved (docs/command_path.md)
    nav2 = yaml.safe_load(default_nav2_params_path().read_text())
    nav2["controller_server"]["ros__parameters"]["cmd_vel_topic"] = "/cmd_vel_unstamped"
    (tmp_path / "nav2.yaml").write_text(yaml.safe_dump(nav2))
    res = runner.invoke(app, ["check", "--stack", str(_stack(tmp_path, "nav2.yaml")),
                              "--duration", "3"])
    assert res.exit_code == 2, res.output
    assert res.output == (
        f"error: {tmp_path / 'nav2.yaml'}: controller_server.ros__parameters.cmd_vel_topic: "
        "publishes on '/cmd_vel_unstamped', outside the command chain (use the velocity "
        "smoother's input '/cmd_vel_nav' (docs/command_path.md))\n")


def test_check_stack_whose_monitor_watches_a_silent_topic_fails(tmp_path: Path) -> None:
    # the collision monitor's source names a topic no sensor publishes: it is stale, so
    # the monitor stops the robot and then goes quiet (stop_pub_timeout)
    nav2 = yaml.safe_load(default_nav2_params_path().read_text())
    nav2["collision_monitor"]["ros__parameters"]["scan"]["topic"] = "/scan_front"
    (tmp_path / "nav2.yaml").write_text(yaml.safe_dump(nav2))
    res = runner.invoke(app, ["check", "--stack", str(_stack(tmp_path, "nav2.yaml")),
                              "--duration", "3"])
    assert res.exit_code == 1, res.output
    assert res.output.splitlines()[-1] == "13/14 checks passed; failed: cmd_vel_published"
    assert "/cmd_vel messages in 2.0 s of active goal" in res.output


def test_check_bad_stack_file_is_one_error_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("world: {name: office, spwan: [1, 1, 0]}\n")
    res = runner.invoke(app, ["check", "--stack", str(bad)])
    assert res.exit_code == 2
    assert res.output == f"error: {bad}: world.spwan: unknown key (did you mean 'spawn'?)\n"
    missing = tmp_path / "nope.yaml"
    res = runner.invoke(app, ["check", "--stack", str(missing)])
    assert res.exit_code == 2
    assert res.output == f"error: {missing}: file not found (check the path)\n"


def test_check_old_spellings_still_work_with_a_warning(tmp_path: Path) -> None:
    # `check STACK --seconds S` was the spelling before --stack / --duration
    res = runner.invoke(app, ["check", str(_stack(tmp_path)), "--seconds", "2"])
    assert res.exit_code == 0, res.output
    assert "warning: a positional STACK_FILE is deprecated; use --stack" in res.output
    assert "warning: --seconds is deprecated; use --duration" in res.output
    assert "(2 s simulated)" in res.output


def test_doctor_cli_names_the_contract_and_exits_1() -> None:
    res = runner.invoke(app, ["doctor", "--fault", "controller_inactive", "--duration", "3"])
    assert res.exit_code == 1, res.output
    lines = res.output.splitlines()
    assert lines[0].startswith("doctor on simulated run (controller_inactive: "
                               "controller_server deactivated, goal (4.00, 7.50))")
    assert "  4. Is the controller server active? BROKEN -- controller_server is INACTIVE" \
        in lines
    assert lines[-2] == ("diagnosis: broken contract 'controller_active': controller_server "
                         "is INACTIVE")
    assert lines[-1].startswith("fix: activate controller_server")


def test_doctor_cli_errors(tmp_path: Path) -> None:
    res = runner.invoke(app, ["doctor", "--fault", "tf_broken"])
    assert res.exit_code == 2
    assert res.output.startswith("error: unknown fault 'tf_broken'")
    res = runner.invoke(app, ["doctor", "--bag", str(tmp_path), "--fault", "healthy"])
    assert res.exit_code == 2
    assert res.output == ("error: --bag diagnoses a recording; do not combine it with "
                          "--world, --robot, --stack, --fault or --record\n")
    res = runner.invoke(app, ["doctor", "--bag", str(tmp_path / "none")])
    assert res.exit_code == 2
    assert res.output.startswith("error: ") and "none" in res.output

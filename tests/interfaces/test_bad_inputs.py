"""Every input validated, no traceback, no hang (issue 14, part 4).

Each case feeds one bad input -- a YAML file (Nav2, stack, robot, slam_toolbox,
robot_localization), a map, a waypoints file, a CARMEN log, a bag, a command-line value
or a web API body -- through the command line (typer's runner, as ``navstack`` runs), the
Python API or the dashboard's HTTP API, and asserts: exit code 2 with exactly one
``error:`` line (a typed :class:`NavstackError` from the API, HTTP 4xx from the web API),
no ``Traceback``, the message names the offending file / option / key, and the case ends
within :data:`CASE_SECONDS` (SIGALRM).  Inputs are small files written to ``tmp_path``.
"""

from __future__ import annotations

import gzip
import json
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import pytest
from PIL import Image
from typer.testing import CliRunner

from navstack.app import app
from navstack.core.errors import NavstackError

CASE_SECONDS = 10.0
runner = CliRunner()
DATA = Path(__file__).resolve().parents[1] / "data"
INTEL = DATA / "carmen" / "intel_excerpt.log"
GOOD_MAP = "image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\n" \
           "occupied_thresh: 0.65\nfree_thresh: 0.25\n"


class CaseTimeout(Exception):
    """A case ran past its budget: the input made navstack hang."""


@pytest.fixture
def deadline() -> Iterator[None]:
    """Fail the case (not the session) if it runs longer than CASE_SECONDS."""
    def expired(signum: int, frame: FrameType | None) -> None:
        raise CaseTimeout(f"case did not finish within {CASE_SECONDS:g} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, CASE_SECONDS)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def write(folder: Path, name: str, text: str | bytes) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def pgm(folder: Path, name: str = "m.pgm", width: int = 20, height: int = 10) -> Path:
    return write(folder, name, f"P5\n{width} {height}\n255\n".encode() + bytes(width * height))


def good_bag(folder: Path) -> Path:
    """A small valid rosbag2 (MCAP) with odometry and scans."""
    from navstack.core.msgs import Header, Odometry
    from navstack.runtime.recording import BagWriter

    w = BagWriter(folder / "good_bag")
    for k in range(200):
        w.write("/odom", Odometry(Header(0.01 * k, "odom"), "base_link"), 0.01 * k)
    w.close()
    return folder / "good_bag"


# --- command line -----------------------------------------------------------------------
@dataclass(frozen=True)
class Cli:
    """``navstack ARGS`` (built in tmp_path) must fail with one line naming ``names``."""

    args: Callable[[Path], list[str]]
    names: Callable[[Path], list[str]]


def _stack(tmp: Path, text: str, nav: str | None = None) -> Path:
    if nav is not None:
        write(tmp, "nav2.yaml", nav)
    return write(tmp, "stack.yaml", text)


def _nav_stack(nav: str) -> Callable[[Path], list[str]]:
    return lambda t: ["check", "--stack", str(_stack(t, "world: {name: office}\n"
                                                      "navigation: nav2.yaml\n", nav))]


def _nav_names(*names: str) -> Callable[[Path], list[str]]:
    return lambda t: [str(t / "nav2.yaml"), *names]


def _existing_bag(t: Path) -> list[str]:
    write(t, "out/bag/metadata.yaml", "rosbag2_bagfile_information: {}\n")
    return ["demo", "--record", "--out", str(t / "out")]


def _truncated(t: Path) -> Path:
    bag = good_bag(t)
    mcap = next(bag.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    return bag


def _map_world(t: Path, image: bytes) -> Path:
    write(t, "m.pgm", image)
    return write(t, "w.yaml", GOOD_MAP)


CLI_CASES: dict[str, Cli] = {
    # numbers out of range, NaN, inf (the option and its range are named)
    "duration-nan": Cli(lambda t: ["sim", "--duration", "nan"],
                        lambda t: ["--duration", "(0, 3600] s", "nan"]),
    "duration-inf": Cli(lambda t: ["sim", "--duration", "inf"],
                        lambda t: ["--duration", "(0, 3600] s"]),
    "duration-negative": Cli(lambda t: ["sim", "--duration", "-5"],
                             lambda t: ["--duration", "(0, 3600] s", "-5"]),
    "duration-huge": Cli(lambda t: ["sim", "--duration", "1e9"],
                         lambda t: ["--duration", "(0, 3600] s", "1000000000"]),
    "check-seconds-huge": Cli(lambda t: ["check", "--seconds", "1e9"],
                              lambda t: ["--seconds", "[0.5, 3600] s"]),
    "check-duration-word": Cli(lambda t: ["check", "--duration", "long"],
                               lambda t: ["--duration", "[0.5, 3600] s", "long"]),
    "doctor-duration-short": Cli(lambda t: ["doctor", "--duration", "0.2"],
                                 lambda t: ["--duration", "[1, 3600] s"]),
    "run-duration-inf": Cli(lambda t: ["run", "--web", "--duration", "inf"],
                            lambda t: ["--duration", "(0, 86400] s"]),
    "replay-duration-huge": Cli(lambda t: ["replay", str(t / "b"), "--duration", "1e12"],
                                lambda t: ["--duration", "(0, 86400] s"]),
    "seed-negative": Cli(lambda t: ["sim", "--seed", "-1"],
                         lambda t: ["--seed", "[0, 4294967295]", "-1"]),
    "seed-fraction": Cli(lambda t: ["demo", "--seed", "1.5"],
                         lambda t: ["--seed", "an integer"]),
    "seed-huge": Cli(lambda t: ["check", "--seed", "99999999999"],
                     lambda t: ["--seed", "[0, 4294967295]"]),
    "rate-zero": Cli(lambda t: ["run", "--web", "--rate", "0"],
                     lambda t: ["--rate", "(0, 1000]"]),
    "replay-rate-negative": Cli(lambda t: ["replay", str(t / "b"), "--rate", "-1"],
                                lambda t: ["--rate", "[0, 1000]"]),
    "port-out-of-range": Cli(lambda t: ["run", "--web", "--port", "70000"],
                             lambda t: ["--port", "[0, 65535]"]),
    "report-decel-nan": Cli(lambda t: ["report", str(t / "b"), "--out", str(t / "o"),
                                       "--braking-decel", "nan"],
                            lambda t: ["--braking-decel", "(0, 100] m/s^2"]),
    "max-scans-zero": Cli(lambda t: ["slam", str(INTEL), "--max-scans", "0"],
                          lambda t: ["--max-scans", "[1, 1000000000]"]),
    "cmd-nan": Cli(lambda t: ["sim", "--cmd", "nan,0"], lambda t: ["--cmd", "finite"]),
    "cmd-huge": Cli(lambda t: ["sim", "--cmd", "1e9,0"],
                    lambda t: ["--cmd", "diff_drive", "vx in [-0.3, 0.5] m/s"]),
    "cmd-one-number": Cli(lambda t: ["sim", "--cmd", "0.2"], lambda t: ["--cmd", "'vx,wz'"]),
    "unknown-option": Cli(lambda t: ["sim", "--durration", "5"],
                          lambda t: ["--durration", "--duration"]),
    "stack-and-amcl": Cli(lambda t: ["run", "--web", "--stack", "s.yaml", "--amcl"],
                          lambda t: ["--stack", "--amcl"]),
    # output paths that are files or cannot be created
    "out-is-a-file": Cli(lambda t: ["demo", "--out", str(write(t, "f.txt", "x"))],
                         lambda t: ["--out", str(t / "f.txt"), "is a file"]),
    "out-under-a-file": Cli(lambda t: ["slam", str(INTEL), "--out",
                                       str(write(t, "f.txt", "x") / "sub")],
                            lambda t: ["--out", str(t / "f.txt")]),
    "json-is-a-folder": Cli(lambda t: ["sim", "--json", str(t)],
                            lambda t: ["--json", str(t), "is a folder"]),
    "report-out-is-a-file": Cli(lambda t: ["report", str(t / "b"), "--out",
                                           str(write(t, "r.md", "x"))],
                                lambda t: ["--out", str(t / "r.md")]),
    "record-over-a-bag": Cli(_existing_bag, lambda t: ["--record", str(t / "out" / "bag"),
                                                       "--force"]),
    "doctor-record-over-a-bag": Cli(
        lambda t: ["doctor", "--record", str(write(t, "old/metadata.yaml", "x").parent)],
        lambda t: ["--record", str(t / "old"), "--force"]),
    # Nav2 parameter files, through a stack file (the file itself is named)
    "nav2-server-key-typo": Cli(
        _nav_stack("controller_server:\n  ros__parameters:\n    controller_frequncy: 10.0\n"),
        _nav_names("controller_server.ros__parameters.controller_frequncy",
                   "did you mean 'controller_frequency'")),
    "nav2-unknown-section": Cli(
        _nav_stack("controler_server:\n  ros__parameters:\n    controller_frequency: 10.0\n"),
        _nav_names("controler_server", "did you mean 'controller_server'")),
    "nav2-empty-file": Cli(_nav_stack(""), _nav_names("empty Nav2 parameter file")),
    "nav2-no-run-section": Cli(
        _nav_stack("map_saver:\n  ros__parameters:\n    save_map_timeout: 5.0\n"),
        _nav_names("no section for a server navstack runs", "map_saver")),
    "nav2-missing-ros-parameters": Cli(
        _nav_stack("planner_server:\n  expected_planner_frequency: 5.0\n"),
        _nav_names("planner_server", "ros__parameters")),
    "nav2-plugin-section-typo": Cli(
        _nav_stack("controller_server:\n  ros__parameters:\n    controller_plugins: "
                   "[FollowPath]\n    FolowPath:\n      plugin: dwb_core::DWBLocalPlanner\n"),
        _nav_names("controller_server.ros__parameters.FolowPath", "'FollowPath'")),
    "nav2-costmap-nested-typo": Cli(
        _nav_stack("global_costmap:\n  global_costmap:\n    ros__parameters:\n"
                   "      update_frequncy: 1.0\n"),
        _nav_names("global_costmap.global_costmap.ros__parameters.update_frequncy",
                   "'update_frequency'")),
    "nav2-params-not-mapping": Cli(
        _nav_stack("bt_navigator:\n  ros__parameters: [1, 2]\n"),
        _nav_names("bt_navigator.ros__parameters", "must be a mapping")),
    "nav2-wildcard-unknown": Cli(
        _nav_stack("/**:\n  ros__parameters:\n    use_sim_tme: true\n"
                   "controller_server:\n  ros__parameters: {}\n"),
        _nav_names("/**.ros__parameters.use_sim_tme")),
    "nav2-bad-yaml": Cli(_nav_stack("controller_server:\n  ros__parameters:\n  - : :\n\t"),
                         _nav_names("invalid YAML")),
    "nav2-file-missing": Cli(
        lambda t: ["check", "--stack", str(_stack(t, "navigation: none.yaml\n"))],
        lambda t: [str(t / "none.yaml"), "file not found"]),
    "nav2-server-wrong-type": Cli(
        _nav_stack("controller_server:\n  ros__parameters:\n    controller_frequency: fast\n"),
        _nav_names("controller_server.controller_frequency", "number")),
    # stack files
    "stack-empty": Cli(lambda t: ["check", "--stack", str(_stack(t, ""))],
                       lambda t: [str(t / "stack.yaml"), "empty stack file"]),
    "stack-unknown-key": Cli(
        lambda t: ["run", "--web", "--stack", str(_stack(t, "worlds: {name: office}\n"))],
        lambda t: [str(t / "stack.yaml"), "worlds", "did you mean 'world'"]),
    "stack-inline-nav-typo": Cli(
        lambda t: ["check", "--stack", str(_stack(
            t, "navigation:\n  planner_server:\n    ros__parameters:\n"
               "      expected_planner_frequncy: 5\n"))],
        lambda t: [f"{t / 'stack.yaml'} (navigation)",
                   "planner_server.ros__parameters.expected_planner_frequncy"]),
    "stack-sim-negative": Cli(
        lambda t: ["check", "--stack", str(_stack(t, "sim: {duration: -1}\n"))],
        lambda t: [str(t / "stack.yaml"), "sim.duration"]),
    "stack-robot-inline-typo": Cli(
        lambda t: ["check", "--stack", str(_stack(
            t, "robot: {name: r, robot_radius: 0.2, kinematics: {max_vel_xx: 1.0}}\n"))],
        lambda t: [str(t / "stack.yaml"), "robot.kinematics.max_vel_xx", "'max_vel_x'"]),
    "stack-world-unknown": Cli(
        lambda t: ["check", "--stack", str(_stack(t, "world: {name: ofice}\n"))],
        lambda t: ["ofice", "did you mean 'office'"]),
    "stack-not-a-mapping": Cli(lambda t: ["check", "--stack", str(_stack(t, "- a\n- b\n"))],
                               lambda t: [str(t / "stack.yaml"), "mapping"]),
    # robot, slam_toolbox and map files on the command line
    "robot-file-empty": Cli(lambda t: ["sim", "--robot", str(write(t, "r.yaml", ""))],
                            lambda t: [str(t / "r.yaml"), "empty robot profile"]),
    "robot-file-bad-footprint": Cli(
        lambda t: ["sim", "--robot", str(write(t, "r.yaml", "footprint: [[0, 0], [1, 0]]\n"
                                                            "kinematics: {max_vel_x: 1}\n"))],
        lambda t: [str(t / "r.yaml"), "footprint"]),
    "slam-params-no-section": Cli(
        lambda t: ["slam", str(INTEL), "--out", str(t / "o"), "--params",
                   str(write(t, "s.yaml", "slam_toolbx:\n  ros__parameters: {}\n"))],
        lambda t: [str(t / "s.yaml"), "slam_toolbox", "did you mean 'slam_toolbx'"]),
    "slam-params-key-typo": Cli(
        lambda t: ["slam", str(INTEL), "--out", str(t / "o"), "--params",
                   str(write(t, "s.yaml", "slam_toolbox:\n  ros__parameters:\n"
                                          "    resolutoin: 0.1\n"))],
        lambda t: [str(t / "s.yaml"), "resolutoin", "'resolution'"]),
    "map-huge-pgm-header": Cli(
        lambda t: ["sim", "--world", str(_map_world(t, b"P5\n30000 30000\n255\n" + bytes(9)))],
        lambda t: [str(t / "m.pgm"), "30000 x 30000", "limit of 40,000,000"]),
    "map-resolution-negative": Cli(
        lambda t: ["sim", "--world", str(write(t, "w.yaml", GOOD_MAP.replace(
            "0.1", "-0.1")))],
        lambda t: [str(t / "w.yaml"), "resolution"]),
    # data files
    "carmen-missing": Cli(lambda t: ["slam", str(t / "nope.log"), "--out", str(t / "o")],
                          lambda t: [str(t / "nope.log"), "not found"]),
    "carmen-no-scans": Cli(lambda t: ["slam", str(write(t, "x.log", "hello\nworld 1 2\n")),
                                      "--out", str(t / "o")],
                           lambda t: [str(t / "x.log"), "no usable laser scans"]),
    "bag-truncated": Cli(lambda t: ["bag", "info", str(_truncated(t))],
                         lambda t: [str(t / "good_bag"), "truncated",
                                    "navstack bag recover"]),
    "bag-not-a-bag": Cli(lambda t: ["report", str(write(t, "x.mcap", "not a bag")), "--out",
                                    str(t / "o")],
                         lambda t: [str(t / "x.mcap")]),
    "bag-unknown-topic": Cli(lambda t: ["replay", str(good_bag(t)), "--topic", "/odm"],
                             lambda t: ["/odm", "did you mean '/odom'"]),
    "bag-recover-not-mcap": Cli(lambda t: ["bag", "recover", str(write(t, "x.db3", "x")),
                                           "--out", str(t / "o")],
                                lambda t: [str(t / "x.db3"), "MCAP"]),
    "waypoints-huge-coordinate": Cli(
        lambda t: ["demo", "--out", str(t / "o"), "--waypoints", str(write(
            t, "w.yaml", "waypoints:\n  - name: far\n    position: {x: 1.0e+300, y: 0}\n"))],
        lambda t: [str(t / "w.yaml"), "waypoints[0].position.x", "±1e+08 m"]),
}


@pytest.mark.parametrize("case", list(CLI_CASES), ids=list(CLI_CASES))
def test_cli_bad_input_is_one_error_line(case: str, tmp_path: Path, deadline: None) -> None:
    spec = CLI_CASES[case]
    res = runner.invoke(app, spec.args(tmp_path))
    out = res.output
    assert res.exit_code == 2, out
    assert "Traceback" not in out
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    errors = [ln for ln in out.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1, out
    for name in spec.names(tmp_path):
        assert name in errors[0], f"{name!r} not in {errors[0]!r}"


# --- Python API -------------------------------------------------------------------------
@dataclass(frozen=True)
class Api:
    """``call(tmp_path)`` must raise ``error`` (a NavstackError) naming ``names``."""

    call: Callable[[Path], Any]
    error: type[NavstackError]
    names: Callable[[Path], list[str]]


def _navstack(nav: Any) -> Any:
    from navstack.interfaces.stack import NavStack

    return NavStack("office", nav2_params=nav)


def _load_map(t: Path, image: bytes | None = None, yaml_text: str = GOOD_MAP) -> Any:
    from navstack.core.map_files import load_map

    if image is not None:
        write(t, "m.pgm", image)
    return load_map(write(t, "m.yaml", yaml_text))


def _png(t: Path, width: int, height: int) -> bytes:
    Image.new("L", (width, height)).save(t / "big.png")
    return (t / "big.png").read_bytes()


def _ekf(t: Path, text: str) -> Any:
    from navstack.localization.ekf.params import load_filter_params

    return load_filter_params(write(t, "ekf.yaml", text))


def _waypoints(t: Path, text: str) -> Any:
    from navstack.navigation.waypoint_follower import load_waypoints

    return load_waypoints(write(t, "wp.yaml", text))


def _carmen(t: Path, data: bytes) -> Any:
    from navstack.mapping.offline import run_carmen

    return run_carmen(write(t, "log.gz", data))


def _bag(t: Path, path: Path) -> Any:
    from navstack.runtime.recording import BagReader

    with BagReader(path) as bag:
        return bag.topics()


def _errors() -> dict[str, type[NavstackError]]:
    from navstack.core.errors import ConfigError, MapFileError, UnknownNameError
    from navstack.mapping.carmen import CarmenLogError
    from navstack.mapping.offline import OfflineSlamError
    from navstack.runtime.recording import BagError

    return {"config": ConfigError, "map": MapFileError, "name": UnknownNameError,
            "carmen": CarmenLogError, "slam": OfflineSlamError, "bag": BagError}


E = _errors()
NAV2_TYPO = {"controller_server": {"ros__parameters": {"controller_frequncy": 10.0}}}

API_CASES: dict[str, Api] = {
    "api-nav2-mapping-typo": Api(lambda t: _navstack(NAV2_TYPO), E["config"], lambda t: [
        "nav2_params argument", "controller_server.ros__parameters.controller_frequncy"]),
    "api-nav2-empty-mapping": Api(lambda t: _navstack({"/**": {}}), E["config"],
                                  lambda t: ["nav2_params argument", "/**"]),
    "api-nav2-top-level-list": Api(lambda t: _navstack(write(t, "n.yaml", "- a\n")),
                                   E["config"], lambda t: [str(t / "n.yaml"), "mapping"]),
    "api-nav2-unknown-node": Api(
        lambda t: _navstack(write(t, "n.yaml", "my_node:\n  ros__parameters: {}\n")),
        E["config"], lambda t: [str(t / "n.yaml"), "my_node", "unknown section"]),
    "api-stack-file-missing": Api(
        lambda t: __import__("navstack.interfaces.stack", fromlist=["NavStack"])
        .NavStack.from_stack_file(t / "none.yaml"), E["config"],
        lambda t: [str(t / "none.yaml"), "file not found"]),
    "api-world-unknown": Api(lambda t: _navstack_world("ofice"), E["name"],
                             lambda t: ["ofice", "office"]),
    "api-map-truncated-pgm": Api(lambda t: _load_map(t, b"P5\n20 10\n255\n\x00\x01"),
                                 E["map"], lambda t: [str(t / "m.pgm"), "truncated"]),
    "api-map-huge-png": Api(lambda t: _load_map(t, _png(t, 9000, 9000),
                                                GOOD_MAP.replace("m.pgm", "big.png")),
                            E["map"], lambda t: [str(t / "big.png"), "9000 x 9000",
                                                 "40,000,000"]),
    "api-map-not-an-image": Api(lambda t: _load_map(t, b"GIF89a garbage"), E["map"],
                                lambda t: [str(t / "m.pgm"), "cannot read map image"]),
    "api-map-yaml-missing-image": Api(
        lambda t: _load_map(t, None, "resolution: 0.1\norigin: [0, 0, 0]\n"), E["map"],
        lambda t: [str(t / "m.yaml"), "'image'"]),
    "api-map-yaml-not-mapping": Api(lambda t: _load_map(t, None, "[1, 2]\n"), E["map"],
                                    lambda t: [str(t / "m.yaml"), "mapping"]),
    "api-map-image-missing": Api(lambda t: _load_map(t, None), E["map"],
                                 lambda t: [str(t / "m.yaml"), "m.pgm", "not found"]),
    "api-map-thresholds": Api(
        lambda t: _load_map(t, bytes(pgm(t).read_bytes()), GOOD_MAP.replace("0.25", "0.9")),
        E["map"], lambda t: [str(t / "m.yaml"), "free_thresh"]),
    "api-ekf-no-section": Api(lambda t: _ekf(t, "ekf_node:\n  ros__parameters: {}\n"),
                              E["config"], lambda t: [str(t / "ekf.yaml"), "ekf_filter_node"]),
    "api-ekf-unknown-key": Api(
        lambda t: _ekf(t, "ekf_filter_node:\n  ros__parameters:\n    frequncy: 30.0\n"),
        E["config"], lambda t: [str(t / "ekf.yaml"), "frequncy", "'frequency'"]),
    "api-ekf-wrong-type": Api(
        lambda t: _ekf(t, "ekf_filter_node:\n  ros__parameters:\n    frequency: fast\n"),
        E["config"], lambda t: [str(t / "ekf.yaml"), "frequency"]),
    "api-ekf-empty": Api(lambda t: _ekf(t, ""), E["config"],
                         lambda t: [str(t / "ekf.yaml"), "ekf_filter_node"]),
    "api-waypoints-nan": Api(
        lambda t: _waypoints(t, "waypoints:\n  - name: a\n    position: {x: .nan, y: 0}\n"),
        E["config"], lambda t: [str(t / "wp.yaml"), "waypoints[0].position.x", "finite"]),
    "api-waypoints-duplicate": Api(
        lambda t: _waypoints(t, "waypoints:\n  - name: a\n    position: {x: 1, y: 0}\n"
                                "  - name: a\n    position: {x: 2, y: 0}\n"),
        E["config"], lambda t: [str(t / "wp.yaml"), "waypoints[1].name", "duplicate"]),
    "api-waypoints-missing-file": Api(
        lambda t: __import__("navstack.navigation.waypoint_follower", fromlist=["x"])
        .load_waypoints(t / "none.yaml"), E["config"], lambda t: [str(t / "none.yaml")]),
    "api-waypoints-empty": Api(lambda t: _waypoints(t, ""), E["config"],
                               lambda t: [str(t / "wp.yaml"), "waypoints"]),
    "api-carmen-corrupt-gzip": Api(
        lambda t: _carmen(t, b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03\xff\xff\xff"),
        E["carmen"], lambda t: [str(t / "log.gz"), "corrupt gzip data"]),
    "api-carmen-truncated-gzip": Api(
        lambda t: _carmen(t, gzip.compress(INTEL.read_bytes())[:200]), E["slam"],
        lambda t: [str(t / "log.gz"), "no usable laser scans"]),
    "api-carmen-binary": Api(lambda t: _carmen(t, bytes(range(256)) * 20), E["slam"],
                             lambda t: [str(t / "log.gz"), "no usable laser scans"]),
    "api-bag-folder-without-bag": Api(lambda t: _bag(t, write(t, "b/x.txt", "x").parent),
                                      E["bag"], lambda t: [str(t / "b"), "metadata.yaml"]),
    "api-bag-unknown-suffix": Api(lambda t: _bag(t, write(t, "b.txt", "x")), E["bag"],
                                  lambda t: [str(t / "b.txt"), "unknown bag format"]),
    "api-bag-truncated-mcap": Api(lambda t: _bag(t, _truncated(t)), E["bag"],
                                  lambda t: [str(t / "good_bag"), "bag recover"]),
}


def _navstack_world(world: str) -> Any:
    from navstack.interfaces.stack import NavStack

    return NavStack(world)


@pytest.mark.parametrize("case", list(API_CASES), ids=list(API_CASES))
def test_api_bad_input_raises_a_typed_error(case: str, tmp_path: Path, deadline: None) -> None:
    spec = API_CASES[case]
    with pytest.raises(spec.error) as info:
        spec.call(tmp_path)
    text = str(info.value)
    assert "Traceback" not in text
    for name in spec.names(tmp_path):
        assert name in text, f"{name!r} not in {text!r}"


def test_navigator_refuses_absurd_goals(deadline: None) -> None:
    """A goal at 1e300 m or NaN is rejected when sent (nav2_simple_commander's contract:
    ``goToPose`` returns False and says why), not accepted and left to hang."""
    from navstack import Navigator, NavStack
    from navstack.core.msgs import Pose2D, PoseStamped

    nav = Navigator(NavStack("office", seed=1))
    for x, why in ((1e300, "outside ±1e+08 m"), (float("nan"), "NaN or inf")):
        assert not nav.goToPose(PoseStamped.from_pose2d(Pose2D(x, 3.0, 0.0), "map"))
        assert why in nav.last_error
    assert nav.goToPose(PoseStamped.from_pose2d(Pose2D(3.0, 3.0, 0.0), "map"))
    assert nav.last_error == ""


# --- web API bodies ---------------------------------------------------------------------
TOKEN = "bad-inputs-token-0123"


@pytest.fixture(scope="module")
def web() -> Iterator[Any]:
    from fastapi.testclient import TestClient

    from navstack.interfaces.live_runner import LiveRunner
    from navstack.interfaces.stack import NavStack
    from navstack.interfaces.web.commands import NavCommander
    from navstack.interfaces.web.model import DashboardModel
    from navstack.interfaces.web.server import create_app

    runner_ = LiveRunner(NavStack("office", seed=1), real_time_factor=1.0)
    runner_.start()
    commander = runner_.call(NavCommander)
    model = DashboardModel(runner_, commander)
    model.attach()
    try:
        with TestClient(create_app(runner_, model, commander, TOKEN)) as client:
            yield client
    finally:
        model.detach()
        runner_.stop()


WEB_CASES: dict[str, tuple[str, str, bytes, int, str]] = {
    # name: (method, path, body, status, text the error names)
    "web-goal-not-json": ("POST", "/api/goal", b"{x: 1", 422, "not JSON"),
    "web-goal-nan": ("POST", "/api/goal", b'{"x": NaN, "y": 1}', 422, "x: Input should be"),
    "web-goal-1e300": ("POST", "/api/goal", b'{"x": 1e300, "y": 1}', 422, "x: Input should be "
                       "less than or equal to 100000000"),
    "web-goal-nested": ("POST", "/api/goal", b'{"x": {"x": {"x": 1}}, "y": 1}', 422, "x:"),
    "web-body-too-large": ("POST", "/api/goal", b" " * 100000 + b"{}", 413, "larger than"),
    "web-goal-deep-nesting": ("POST", "/api/goal", b"[" * 30000 + b"]" * 30000, 422,
                              "not JSON"),
    "web-goal-extra-field": ("POST", "/api/goal", b'{"x": 1, "y": 1, "z": 2}', 422, "z:"),
    "web-goal-missing-y": ("POST", "/api/goal", b'{"x": 1}', 422, "y: Field required"),
    "web-goal-string": ("POST", "/api/goal", b'{"x": "one", "y": 1}', 422, "x:"),
    "web-waypoint-theta-inf": ("POST", "/api/waypoints", b'{"x": 1, "y": 1, "theta": "inf"}',
                               422, "theta:"),
    "web-go-mode": ("POST", "/api/waypoints/go", b'{"mode": "teleport"}', 422, "mode:"),
    "web-estop-reason-long": ("POST", "/api/estop", json.dumps({"reason": "x" * 500}).encode(),
                              422, "reason:"),
    "web-body-a-list": ("POST", "/api/cancel", b"[1, 2, 3]", 422, "cancel"),
}


@pytest.mark.parametrize("case", list(WEB_CASES), ids=list(WEB_CASES))
def test_web_api_bad_body_is_4xx_naming_the_field(case: str, web: Any,
                                                  deadline: None) -> None:
    method, path, body, status, text = WEB_CASES[case]
    r = web.request(method, path, content=body, headers={
        "Authorization": f"Bearer {TOKEN}", "Content-Type": "application/json"})
    assert r.status_code == status, r.text
    assert 400 <= r.status_code < 500
    error = r.json()["error"]
    assert text in error and "Traceback" not in error


# --- the real entry point ---------------------------------------------------------------
@pytest.mark.parametrize("args", [["sim", "--duration", "nan"], ["bogus-command"],
                                  ["sim", "--world", "/nonexistent/w.yaml"]],
                         ids=["nan", "unknown-command", "missing-world"])
def test_console_entry_point_exits_2_without_traceback(args: list[str]) -> None:
    res = subprocess.run([sys.executable, "-m", "navstack.app", *args], capture_output=True,
                         text=True, timeout=CASE_SECONDS * 3)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr + res.stdout
    assert [ln for ln in res.stderr.splitlines() if ln.startswith("error:")] == \
        res.stderr.strip().splitlines()[-1:]


def test_case_count_meets_the_acceptance() -> None:
    distinct = len(CLI_CASES) + len(API_CASES) + len(WEB_CASES) + 1  # + navigator goals
    assert distinct >= 60, distinct


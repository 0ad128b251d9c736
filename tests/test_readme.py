"""Every command shown in README.md runs, from the repository root, as a fresh clone has it.

The shell commands of the README's ```bash blocks are extracted and each is looked up in
:data:`FORMS`, which says how CI runs it: as written, in a reduced form (fewer scans,
``--quick``, one waypoint; outputs into a temporary folder), or — for the ``make`` targets —
by checking what the target runs, because CI runs those targets itself.  A command the
README shows that :data:`FORMS` does not know fails the test, and so does a form whose
command left the README, so the two cannot drift apart.  The README's Python blocks run
as written.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BIN = Path(sys.executable).parent
"""The environment running the tests; under ``make test`` this is the README's ``.venv/bin``."""
TIMEOUT_S = 300.0


def fenced_blocks(text: str) -> list[tuple[str, str]]:
    """``(language, body)`` of every fenced code block."""
    return [(m.group(1), m.group(2))
            for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.MULTILINE | re.DOTALL)]


def readme_commands() -> list[str]:
    """The shell commands of the README's bash blocks, comments removed, one per line."""
    commands = []
    for lang, body in fenced_blocks(README.read_text()):
        if lang in ("bash", "sh", "shell", "console"):
            for line in body.splitlines():
                argv = shlex.split(line, comments=True)
                if argv:
                    commands.append(shlex.join(argv))
    return commands


def readme_python() -> list[str]:
    return [body for lang, body in fenced_blocks(README.read_text()) if lang == "python"]


@dataclass(frozen=True)
class Run:
    """Run the README command with options replaced (``set``) and arguments added."""

    expect: str
    """A line the command must print (substring), the outcome it promises."""
    set: dict[str, str] = field(default_factory=dict)
    add: tuple[str, ...] = ()
    json: str = ""
    """Option whose file must hold valid JSON afterwards."""
    why: str = ""
    """Why the CI form differs from the README's (timings on the 2-core CI machine)."""


@dataclass(frozen=True)
class Covered:
    """A ``make`` target: CI runs it itself; ``check`` proves what it runs."""

    why: str
    check: Callable[[], None]


def _make_recipe(target: str) -> tuple[list[str], list[str]]:
    """``(prerequisites, recipe lines)`` of a Makefile target, with ``$(BIN)``/``$(OUT)``
    replaced by their values."""
    text = (ROOT / "Makefile").read_text()
    values = dict(re.findall(r"^(\w+) \??:?= *(.*)$", text, re.MULTILINE))
    match = re.search(rf"^{target}:(.*)\n((?:\t.*\n)*)", text, re.MULTILINE)
    assert match, f"Makefile has no target {target}"
    recipe = match.group(2)
    for _ in range(3):  # nested variables: BIN := $(VENV)/bin
        recipe = re.sub(r"\$\((\w+)\)", lambda m: values.get(m.group(1), m.group(0)), recipe)
    return match.group(1).split(), [line.strip() for line in recipe.splitlines()]


def _check_make_demo() -> None:
    _, recipe = _make_recipe("demo")
    assert recipe == [".venv/bin/navstack demo --out runs/demo --seed 1"]
    assert recipe[0] in readme_commands()  # and that command's CI form runs below


def _check_make_test() -> None:
    prerequisites, _ = _make_recipe("test")
    assert {"lint", "typecheck", "pytest", "docs"} <= set(prerequisites)
    assert "make test" in (ROOT / ".ci" / "run").read_text().splitlines()


def _check_make_docs() -> None:
    _, recipe = _make_recipe("docs")
    assert any("mkdocs build --strict" in line for line in recipe), recipe
    prerequisites, _ = _make_recipe("test")
    assert "docs" in prerequisites


ONE_GOAL = """waypoints:
  - name: Near
    position: {x: 2.5, y: 7.5, z: 0.0}
    orientation: {x: 0.0, y: 0.0, z: 0.0, w: 1.0}
order: [Near]
"""
"""One goal 1.5 m ahead of the office spawn pose (1.0, 7.5)."""

FORMS: dict[str, Run | Covered] = {
    "make demo": Covered("CI checks the target's recipe is the README's `navstack demo` "
                         "command, whose reduced form runs here", _check_make_demo),
    "make test": Covered(".ci/run runs `make test` (this test is part of it)",
                         _check_make_test),
    "make docs": Covered("`make test` builds the docs strictly (target `docs`)",
                         _check_make_docs),
    ".venv/bin/navstack --help": Run(expect="Usage: navstack"),
    ".venv/bin/navstack worlds": Run(expect="office"),
    ".venv/bin/navstack robots": Run(expect="golf_cart"),
    ".venv/bin/navstack sim --world office --robot diff_drive --duration 20 --cmd 0.3,0.1 "
    "--seed 1 --json runs/sim.json": Run(expect="collisions", set={"--json": "{tmp}/sim.json"},
                                         json="--json"),
    ".venv/bin/navstack demo --out runs/demo --seed 1": Run(
        expect="SUCCESS: 1/1 goals, 0 collisions", set={"--out": "{tmp}/demo"},
        add=("--waypoints", "{tmp}/one_goal.yaml"),
        why="the four-goal mission takes ~40 s; one goal 1.5 m from the spawn runs the "
            "same command path (plan, control, report) in ~3 s"),
    ".venv/bin/navstack slam src/navstack/data/carmen/intel-corrected.log.gz "
    "--out runs/intel": Run(
        expect="50 scans processed", set={"--out": "{tmp}/intel"}, add=("--max-scans", "50"),
        why="the 910 scans take ~35 s; 50 scans read the same shipped log in ~2 s"),
    ".venv/bin/navstack bench list": Run(expect="slam-params"),
    ".venv/bin/navstack bench sim --json runs/bench-sim.json": Run(
        expect="navstack bench sim", set={"--json": "{tmp}/bench-sim.json"}, json="--json"),
    ".venv/bin/navstack bench planners --quick": Run(expect="optimal_rate"),
    ".venv/bin/navstack bench slam --json runs/slam.json": Run(
        expect="intel_trans_err_m", set={"--json": "{tmp}/slam.json"}, add=("--quick",),
        json="--json",
        why="the full logs and four-goal mapping run take minutes; --quick runs the first "
            "150 scans of each shipped log and two goals (~45 s)"),
}


def ci_argv(command: str, form: Run, tmp: Path) -> list[str]:
    """The argv CI runs for a README command."""
    argv = shlex.split(command)
    if argv[0].startswith(".venv/bin/"):
        argv[0] = str(BIN / argv[0].removeprefix(".venv/bin/"))
    for option, value in form.set.items():
        assert option in argv, f"{option} is no longer in the README command {command!r}"
        argv[argv.index(option) + 1] = value.format(tmp=tmp)
    return argv + [a.format(tmp=tmp) for a in form.add]


def test_every_readme_command_has_a_ci_form() -> None:
    shown = readme_commands()
    assert shown, "no commands found in README.md"
    unknown = [c for c in shown if c not in FORMS]
    stale = [c for c in FORMS if c not in shown]
    assert not unknown, f"README commands with no CI form in tests/test_readme.py: {unknown}"
    assert not stale, f"CI forms of commands no longer in README.md: {stale}"


def test_reduced_forms_say_why() -> None:
    for command, form in FORMS.items():
        if isinstance(form, Run) and (form.add or set(form.set) - {"--json", "--out"}):
            assert form.why, f"{command}: a reduced form must say why"


@pytest.mark.parametrize("command", readme_commands())
def test_readme_command_runs(command: str, tmp_path: Path) -> None:
    form = FORMS.get(command)
    if form is None:
        pytest.fail(f"no CI form for README command {command!r} (add it to FORMS)")
    if isinstance(form, Covered):
        form.check()
        return
    (tmp_path / "one_goal.yaml").write_text(ONE_GOAL)
    argv = ci_argv(command, form, tmp_path)
    res = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, timeout=TIMEOUT_S,
                         stdin=subprocess.DEVNULL)
    output = res.stdout + res.stderr
    assert res.returncode == 0, f"{shlex.join(argv)} exited {res.returncode}:\n{output}"
    assert "Traceback" not in output
    assert form.expect in output, f"{shlex.join(argv)} did not print {form.expect!r}:\n{output}"
    if form.json:
        written = Path(argv[argv.index(form.json) + 1])
        assert isinstance(json.loads(written.read_text()), dict)


PYTHON_EXPECT = ["TaskResult.SUCCEEDED"]
"""What each README Python block prints, in order."""


def test_readme_python_blocks_run() -> None:
    blocks = readme_python()
    assert len(blocks) == len(PYTHON_EXPECT), "a README Python block has no expected output"
    for block, expect in zip(blocks, PYTHON_EXPECT, strict=True):
        res = subprocess.run([sys.executable, "-c", block], cwd=ROOT, capture_output=True,
                             text=True, timeout=TIMEOUT_S, stdin=subprocess.DEVNULL)
        assert res.returncode == 0, res.stderr
        assert expect in res.stdout, res.stdout + res.stderr

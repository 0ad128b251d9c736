"""The ``navstack`` typer application and the helpers every command group shares.

Every subcommand has ``--help``.  Errors that a user can fix (bad config, unknown world,
missing map file) print one line ``error: ...`` and exit with code 2 — never a traceback.
Heavy modules are imported inside the commands so ``navstack --help`` stays instant.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

app = typer.Typer(help="navstack: autonomous navigation for mobile robots, with a built-in "
                  "simulator.", no_args_is_help=True, add_completion=False,
                  pretty_exceptions_enable=False)


def fail(message: str) -> typer.Exit:
    """Print ``error: message`` on stderr; raise the returned Exit (code 2)."""
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(code=2)


def write_json(path: Path | None, payload: dict[str, object]) -> None:
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(payload, indent=2, default=float) + "\n")


def slam_overrides(params: Path | None) -> dict[str, Any] | None:
    """The ``slam_toolbox: ros__parameters:`` section of a parameter file, if given."""
    if params is None:
        return None
    from navstack.core.config_files import load_yaml, ros_parameters

    return dict(ros_parameters(load_yaml(params), "slam_toolbox", file=str(params),
                               required=True))


def parse_cmd(text: str) -> tuple[float, float]:
    try:
        parts = [float(v) for v in text.split(",")]
    except ValueError:
        raise fail(f"--cmd '{text}' must be two numbers 'vx,wz' (e.g. 0.3,0.2)") from None
    if len(parts) != 2:
        raise fail(f"--cmd '{text}' must be two numbers 'vx,wz' (e.g. 0.3,0.2)")
    return parts[0], parts[1]


def one_line(exc: Exception) -> str:
    return "; ".join(line for line in str(exc).splitlines() if line)

"""The ``navstack`` typer application and the helpers every command group shares.

Every subcommand has ``--help`` (and ``-h``).  Errors that a user can fix (bad config,
unknown world, missing map file, an option out of range, an unknown option) print one
line ``error: ...`` and exit with code 2 -- never a traceback, never a usage box.  Help
is plain text (no rich markup), so units in brackets such as ``[m/s, rad/s]`` are shown
as written.  Heavy modules are imported inside the commands so ``navstack --help`` stays
instant.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import logging
import math
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer
from typer.core import TyperGroup

from navstack.core.errors import NavstackError

# typer >= 0.2x carries its own copy of click (``typer._click``); older typer uses click
click: Any = importlib.import_module(
    "typer._click" if importlib.util.find_spec("typer._click") else "click")

_ABORT = (typer.Abort, getattr(click.exceptions, "Abort", typer.Abort))
CONTEXT = {"help_option_names": ["-h", "--help"]}


def usage_line(exc: Any) -> str:
    """One line for a usage error: the option, what is wrong, where help is."""
    errors = click.exceptions
    if isinstance(exc, errors.BadParameter) and not isinstance(exc, errors.MissingParameter):
        hint = exc.param_hint
        if hint is None and exc.param is not None:
            opts = exc.param.opts or [exc.param.human_readable_name]
            hint = opts[0] if exc.param.param_type_name == "option" else opts[0].upper()
        if isinstance(hint, Sequence) and not isinstance(hint, str):
            hint = hint[0] if hint else None
        text = f"{hint}: {exc.message}" if hint else exc.message
    else:
        text = exc.format_message()
    text = " ".join(text.split())
    ctx = getattr(exc, "ctx", None)
    if ctx is not None and isinstance(exc, click.exceptions.UsageError):
        text += f" (see '{ctx.command_path} --help')"
    return text


class NavstackGroup(TyperGroup):
    """The root command: usage errors and :class:`NavstackError` become one ``error:``
    line with exit code 2 (click would print a usage box; typer a rich panel)."""

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             windows_expand_args: bool = True, **extra: Any) -> Any:
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, False, windows_expand_args,
                                **extra)
        show_config_notes()
        try:
            code = super().main(args, prog_name or "navstack", complete_var, False,
                                windows_expand_args, **extra)
        except click.exceptions.NoArgsIsHelpError as exc:
            typer.echo(exc.format_message())
            sys.exit(2)
        except click.exceptions.ClickException as exc:
            typer.echo(f"error: {usage_line(exc)}", err=True)
            sys.exit(2)
        except _ABORT:
            typer.echo("Aborted.", err=True)
            sys.exit(130)
        except NavstackError as exc:  # last line of defence: one line, no traceback
            typer.echo(f"error: {one_line(exc)}", err=True)
            sys.exit(2)
        sys.exit(code if isinstance(code, int) else 0)


class _NoteHandler(logging.Handler):
    """``note: ...`` lines on the current stderr (what the config loaders say: sections
    merged from the packaged defaults, Nav2 nodes and keys ignored)."""

    def emit(self, record: logging.LogRecord) -> None:
        typer.echo(f"note: {record.getMessage()}", err=True)


def show_config_notes() -> None:
    """Print the ``navstack.config`` log as note lines (installed once per process)."""
    logger = logging.getLogger("navstack.config")
    if not any(isinstance(h, _NoteHandler) for h in logger.handlers):
        logger.addHandler(_NoteHandler(logging.INFO))
        logger.setLevel(logging.INFO)


def command_group(help: str, **kwargs: Any) -> typer.Typer:
    """A typer app with navstack's settings: plain help, ``-h``, no rich tracebacks."""
    return typer.Typer(help=help, no_args_is_help=True, add_completion=False,
                       pretty_exceptions_enable=False, rich_markup_mode=None,
                       context_settings=CONTEXT, **kwargs)


app = command_group("navstack: autonomous navigation for mobile robots, with a built-in "
                    "simulator.", cls=NavstackGroup)


def _version(value: bool) -> None:
    if value:
        from navstack import __version__

        typer.echo(f"navstack {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: Annotated[bool, typer.Option(
        "--version", "-V", is_eager=True, callback=_version,
        help="Print the navstack version and exit.")] = False) -> None:
    """navstack: autonomous navigation for mobile robots, with a built-in simulator."""


def fail(message: str) -> typer.Exit:
    """Print ``error: message`` on one line on stderr; raise the returned Exit (code 2).

    Several problems (a :class:`~navstack.core.errors.ConfigErrors`) are joined by "; "."""
    typer.echo(f"error: {'; '.join(ln for ln in message.splitlines() if ln)}", err=True)
    return typer.Exit(code=2)


def warn(message: str) -> None:
    """Print a warning line on stderr."""
    typer.echo(message, err=True)


class Terminated(KeyboardInterrupt):
    """SIGTERM, delivered like Ctrl-C so every ``finally`` (closing a bag) runs."""


TERMINATED_EXIT = 128 + signal.SIGTERM


@contextmanager
def stop_on_sigterm() -> Iterator[None]:
    """Inside the block SIGTERM ends the command the way Ctrl-C does: ``finally`` blocks
    run (a recording is closed and stays readable), then the command exits with 143.
    Python's default SIGTERM action would kill the process mid-write instead."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_sigterm(signum: int, frame: object) -> None:
        raise Terminated

    previous = signal.signal(signal.SIGTERM, on_sigterm)
    try:
        yield
    except Terminated:
        typer.echo("stopped by SIGTERM", err=True)
        raise typer.Exit(code=TERMINATED_EXIT) from None
    finally:
        signal.signal(signal.SIGTERM, previous)


def write_json(path: Path | None, payload: dict[str, object]) -> None:
    if path is None:
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(payload, indent=2, default=float) + "\n")
    except OSError as exc:
        raise fail(f"--json {path}: cannot write ({exc.strerror or exc})") from None


def slam_overrides(params: Path | None) -> dict[str, Any] | None:
    """The ``slam_toolbox: ros__parameters:`` section of a parameter file, if given."""
    if params is None:
        return None
    from navstack.core.config_files import load_yaml, ros_parameters

    return dict(ros_parameters(load_yaml(params), "slam_toolbox", file=str(params),
                               required=True))


CMD_FORMAT = "two numbers 'vx,wz' [m/s, rad/s] (e.g. 0.3,0.2)"


def parse_cmd(text: str) -> tuple[float, float]:
    """``'vx,wz'`` as two finite numbers; the robot's limits are checked by the caller."""
    try:
        parts = [float(v) for v in text.split(",")]
    except ValueError:
        raise fail(f"--cmd '{text}' must be {CMD_FORMAT}") from None
    if len(parts) != 2:
        raise fail(f"--cmd '{text}' must be {CMD_FORMAT}")
    if not all(math.isfinite(v) for v in parts):
        raise fail(f"--cmd '{text}': both numbers must be finite ({CMD_FORMAT})")
    return parts[0], parts[1]


def one_line(exc: Exception) -> str:
    return "; ".join(line for line in str(exc).splitlines() if line)

"""Checked command-line values: bounded numbers, output paths, deprecated spellings.

Every number a command takes has a stated range and must be finite; a value outside it
ends the command before any work with one line naming the option and the range
(``error: --duration: must be a number in (0, 3600] s, got nan``).  Runs are bounded:
batch simulations take at most :data:`MAX_BATCH_SECONDS` simulated seconds, live and
replay sessions at most :data:`MAX_LIVE_SECONDS` (without ``--duration`` a live session
runs until Ctrl-C, by design).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import typer

MAX_BATCH_SECONDS = 3600.0
"""Longest simulated run of ``sim``, ``check`` and ``doctor`` [s] (one hour)."""
MAX_LIVE_SECONDS = 86400.0
"""Longest ``run`` / ``replay`` session given with ``--duration`` [s] (one day)."""
SEED_MAX = 2**32 - 1
"""numpy seeds are unsigned 32-bit words (``SeedSequence``)."""
MAX_RATE = 1000.0
"""Largest real-time factor (simulated seconds per wall second) a paced run accepts."""


def _num(value: float) -> str:
    if float(value).is_integer() and abs(value) < 1e16:
        return str(int(value))
    return f"{value:g}"


class Bounded:
    """Parser of one number in a range (``typer.Option(parser=...)``).

    ``low_open`` / ``high_open`` exclude the bound.  ``integer`` refuses fractions.  NaN
    and infinities are always refused.  The error names the range and the unit.
    """

    def __init__(self, low: float, high: float, *, unit: str = "", low_open: bool = False,
                 high_open: bool = False, integer: bool = False) -> None:
        self.low, self.high = low, high
        self.low_open, self.high_open = low_open, high_open
        self.integer = integer
        self.unit = unit
        self.__name__ = "integer" if integer else "number"

    @property
    def range_text(self) -> str:
        lo = ("(" if self.low_open else "[") + _num(self.low)
        hi = _num(self.high) + (")" if self.high_open else "]")
        return f"{lo}, {hi}" + (f" {self.unit}" if self.unit else "")

    def __call__(self, value: Any) -> float | int:
        kind = "an integer" if self.integer else "a number"
        problem = f"must be {kind} in {self.range_text}, got {value!r}"
        if isinstance(value, bool):
            raise typer.BadParameter(problem)
        if isinstance(value, int | float):
            number: float | int = value
        else:
            text = str(value).strip()
            try:
                number = int(text) if self.integer else float(text)
            except ValueError:
                raise typer.BadParameter(problem) from None
        if self.integer and isinstance(number, float):
            if not number.is_integer():
                raise typer.BadParameter(problem)
            number = int(number)
        if not math.isfinite(number):
            raise typer.BadParameter(problem)
        too_low = number <= self.low if self.low_open else number < self.low
        too_high = number >= self.high if self.high_open else number > self.high
        if too_low or too_high:
            raise typer.BadParameter(f"must be {kind} in {self.range_text}, got {_num(number)}")
        return number


def number_option(*names: str, help: str, low: float, high: float, unit: str = "",
                  low_open: bool = False, high_open: bool = False, integer: bool = False,
                  metavar: str | None = None, hidden: bool = False) -> Any:
    """A ``typer.Option`` holding a bounded number; the range is appended to the help."""
    parser = Bounded(low, high, unit=unit, low_open=low_open, high_open=high_open,
                     integer=integer)
    return typer.Option(*names, parser=parser, help=f"{help} Range {parser.range_text}.",
                        metavar=metavar or ("INTEGER" if integer else "NUMBER"), hidden=hidden)


def duration_option(help: str, high: float = MAX_BATCH_SECONDS, low: float = 0.0,
                    low_open: bool = True) -> Any:
    """``--duration SECONDS``: simulated seconds, one spelling across every command."""
    return number_option("--duration", help=help, low=low, high=high, unit="s",
                         low_open=low_open, metavar="SECONDS")


def seconds_alias(low: float = 0.0, high: float = MAX_BATCH_SECONDS,
                  low_open: bool = True) -> Any:
    """The old ``--seconds`` spelling of ``--duration`` (hidden, deprecated)."""
    return number_option("--seconds", help="Deprecated spelling of --duration.", low=low,
                         high=high, unit="s", low_open=low_open, metavar="SECONDS",
                         hidden=True)


def seed_option(help: str = "Random seed (same seed, same run).") -> Any:
    return number_option("--seed", help=help, low=0, high=SEED_MAX, integer=True)


def rate_option(help: str) -> Any:
    return number_option("--rate", help=help, low=0.0, high=MAX_RATE, low_open=True,
                         unit="x real time")


def port_option(*names: str, help: str) -> Any:
    return number_option(*names, help=help, low=0, high=65535, integer=True, metavar="PORT")


def prefer(new_name: str, new_value: Any, old_name: str, old_value: Any,
           warn: Callable[[str], None]) -> Any:
    """The value of a renamed option: the old spelling still works, with a warning."""
    if old_value is None:
        return new_value
    warn(f"warning: {old_name} is deprecated; use {new_name}")
    return old_value


# --- output paths ----------------------------------------------------------------------
def _nearest_existing(path: Path) -> Path:
    p = path.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_out_dir(path: Path, option: str) -> None:
    """``path`` is a writable folder or can be created as one; ``BadParameter`` naming
    ``option`` otherwise.  Nothing is created: a command that fails on its input leaves
    no empty output folder behind."""
    hint = typer.BadParameter
    if path.exists() and not path.is_dir():
        raise hint(f"{path} is a file, not a folder; give a folder (it is created if "
                   "missing)", param_hint=option)
    base = _nearest_existing(path)
    if not base.is_dir():
        raise hint(f"{base} is a file, so folder {path} cannot be created; give a path in a "
                   "folder", param_hint=option)
    if not os.access(base, os.W_OK | os.X_OK):
        raise hint(f"folder {base} is not writable, so {path} cannot be written; give a "
                   "writable folder", param_hint=option)


def check_out_file(path: Path, option: str) -> None:
    """``path`` can be written as a file (not a folder, its folder exists or can be
    created, writable); ``BadParameter`` naming ``option``."""
    if path.is_dir():
        raise typer.BadParameter(f"{path} is a folder; give a file name", param_hint=option)
    if path.exists() and not os.access(path, os.W_OK):
        raise typer.BadParameter(f"{path} is not writable; give a writable path",
                                 param_hint=option)
    check_out_dir(path.parent, option)

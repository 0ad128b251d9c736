"""Composition root of the ``navstack`` command: every command group, benchmarks included.

``navstack.interfaces.cli`` holds the user commands; ``navstack.benchmarks.cli`` the
``bench`` command, which sits above the interfaces layer because suites drive the whole
stack.  This module imports both so neither layer imports the other upwards.
"""

from __future__ import annotations

import sys

import typer

from navstack.benchmarks import cli as _bench_cli  # noqa: F401  (registers `bench`)
from navstack.core.errors import NavstackError
from navstack.interfaces.cli import app

__all__ = ["app", "main"]


def main() -> None:
    """Console entry point."""
    try:
        app()
    except NavstackError as exc:  # last line of defence: one line, no traceback
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)


if __name__ == "__main__":
    main()

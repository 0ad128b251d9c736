"""Composition root of the ``navstack`` command: every command group, benchmarks included.

``navstack.interfaces.cli`` holds the user commands; ``navstack.benchmarks.cli`` the
``bench`` command, which sits above the interfaces layer because suites drive the whole
stack.  This module imports both so neither layer imports the other upwards.  Usage
errors and :class:`~navstack.core.errors.NavstackError` end as one ``error:`` line with
exit code 2 (:class:`~navstack.interfaces.cli.common.NavstackGroup`).
"""

from __future__ import annotations

from navstack.benchmarks import cli as _bench_cli  # noqa: F401  (registers `bench`)
from navstack.interfaces.cli import app

__all__ = ["app", "main"]


def main() -> None:
    """Console entry point."""
    app()


if __name__ == "__main__":
    main()

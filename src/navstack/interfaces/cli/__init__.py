"""The ``navstack`` command line (typer), one module per command group.

The command groups register themselves on :data:`~navstack.interfaces.cli.common.app`
when imported; :mod:`navstack.app` is the composition root that also adds the benchmark
commands (which sit above this layer) and is the console entry point.
"""

from navstack.interfaces.cli import (
    bag_cmds,
    demo_cmds,
    health_cmds,
    link_cmds,
    sim_cmds,
    slam_cmds,
    telegram_cmds,
)
from navstack.interfaces.cli.common import app

__all__ = ["app", "bag_cmds", "demo_cmds", "health_cmds", "link_cmds", "sim_cmds", "slam_cmds",
           "telegram_cmds"]

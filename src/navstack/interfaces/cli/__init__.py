"""The ``navstack`` command line (typer), one module per command group.

The command groups register themselves on :data:`~navstack.interfaces.cli.common.app`
when imported; :mod:`navstack.app` is the composition root that also adds the benchmark
commands (which sit above this layer) and is the console entry point.
"""

from navstack.interfaces.cli import (
    aruco_cmds,
    bag_cmds,
    demo_cmds,
    fleet_cmds,
    health_cmds,
    link_cmds,
    mission_cmds,
    sim_cmds,
    slam_cmds,
    split_cmds,
    telegram_cmds,
    teleop_cmds,
)
from navstack.interfaces.cli.common import app

__all__ = ["app", "aruco_cmds", "bag_cmds", "demo_cmds", "fleet_cmds", "health_cmds", "link_cmds",
           "mission_cmds", "sim_cmds", "slam_cmds", "split_cmds", "telegram_cmds",
           "teleop_cmds"]

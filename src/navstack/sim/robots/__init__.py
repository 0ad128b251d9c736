"""Built-in robot profiles (``<name>.yaml``); load them with ``navstack.sim.robot.load_robot``.

- ``turtlebot``: TurtleBot3 Waffle-class differential drive (Nav2's reference robot).
- ``diff_drive``: a generic 0.5 m/s indoor differential-drive base.
- ``omni``: a holonomic (mecanum) base with a rectangular footprint.
- ``golf_cart``: an Ackermann (car-like) campus vehicle with a 270 degree lidar.
"""

from __future__ import annotations

from pathlib import Path

ROBOTS_DIR = Path(__file__).resolve().parent
"""Directory holding the built-in profile YAML files."""

"""The split office stack and a one-goal route, shared by the split and clock tests."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

STACK = Path(str(resources.files("navstack") / "config" / "split_office.yaml"))
ONE_GOAL = """\
waypoints:
  - name: Goal_1
    position: {x: 2.5, y: 4.0, z: 0.0}
order: [Goal_1]
"""

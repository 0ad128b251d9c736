"""Truth figures of the perception missions (issue 17) for the mission report.

The missions see the world only through the bus; the report judges them against the
simulator's truth:

* ``marker-frame``: the error of the static frame ``map -> aruco_marker_<id>`` (TF at the
  end) against the world's marker -- ``marker_position_error_m``,
  ``marker_angle_error_deg`` -- and ``marker_frame_ok`` (within 0.10 m and 5 deg, the
  issue's tolerance);
* ``package-retrieval``: ``package_held`` (the gripper holds the target package),
  ``package_collisions`` (contacts of the robot's body with any package) and
  ``packages`` (where they were placed).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navstack.core.errors import TransformError
from navstack.core.rotations import rotation_angle, transform_to_matrix
from navstack.interfaces.stack import NavStack

__all__ = ["ANGLE_TOL_DEG", "POSITION_TOL", "perception_figures"]

POSITION_TOL = 0.10
"""Marker frame position tolerance [m] (issue 17, acceptance 2)."""
ANGLE_TOL_DEG = 5.0
"""Marker frame rotation tolerance [deg]."""


def marker_frame_error(stack: NavStack, marker_id: int) -> tuple[float, float]:
    """Position [m] and rotation [deg] error of ``map -> aruco_marker_<id>`` against the
    world's marker; ``(inf, inf)`` when TF has no such frame."""
    truth = next((mk for mk in stack.world.markers if mk.id == marker_id), None)
    if truth is None:
        return math.inf, math.inf
    try:
        tf = transform_to_matrix(stack.runtime.tf.lookup("map", f"aruco_marker_{marker_id}")
                                 .transform)
    except TransformError:
        return math.inf, math.inf
    pos = float(np.linalg.norm(tf[:3, 3] - [truth.x, truth.y, truth.z]))
    return pos, math.degrees(rotation_angle(tf[:3, :3], truth.rotation()))


def perception_figures(stack: NavStack, report: dict[str, Any]) -> dict[str, Any]:
    """The module docstring's figures for ``report['mission']`` ({} for other missions)."""
    mission = report.get("mission")
    if mission == "marker-frame" and "marker_id" in report:
        pos, ang = marker_frame_error(stack, int(report["marker_id"]))
        return {"marker_position_error_m": round(pos, 4),
                "marker_angle_error_deg": round(ang, 3),
                "marker_frame_ok": bool(pos <= POSITION_TOL and ang <= ANGLE_TOL_DEG)}
    if mission == "package-retrieval" and "target_id" in report:
        packages = stack.sim.sim.packages
        carried = packages.carried
        held = carried is not None and packages.specs[carried].marker_id == report["target_id"]
        return {"package_held": bool(held),
                "package_collisions": int(packages.total_collisions),
                "packages": [[p.marker_id, round(p.x, 2), round(p.y, 2)]
                             for p in packages.specs]}
    return {}

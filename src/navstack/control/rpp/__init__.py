"""Regulated Pure Pursuit controller with Nav2 ``nav2_regulated_pure_pursuit_controller``
semantics.

``RegulatedPurePursuitController(params, footprint=...).compute(pose, velocity, path,
costmap, now) -> Twist2D`` for differential-drive and (with ``min_turning_radius``)
car-like robots; see :mod:`navstack.control.rpp.controller`.
"""

from navstack.control.rpp.collision import CollisionHit, RPPCollisionChecker, project_arc
from navstack.control.rpp.controller import RegulatedPurePursuitController
from navstack.control.rpp.errors import CollisionAhead, CostmapTooSmall
from navstack.control.rpp.params import RegulatedPurePursuitParams
from navstack.control.rpp.path_handler import PathHandler

RPPController = RegulatedPurePursuitController
"""Alias: the short navstack name."""

__all__ = [
    "CollisionAhead", "CollisionHit", "CostmapTooSmall", "PathHandler",
    "RPPCollisionChecker", "RPPController", "RegulatedPurePursuitController",
    "RegulatedPurePursuitParams", "project_arc",
]

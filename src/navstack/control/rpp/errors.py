"""Regulated Pure Pursuit failure types (subclasses of the core controller errors)."""

from __future__ import annotations

from navstack.core.errors import NoValidControl


class CollisionAhead(NoValidControl):
    """The commanded arc runs into a lethal cell within the collision lookahead
    (Nav2: ``NoValidControl("RegulatedPurePursuitController detected collision ahead!")``).

    ``pose`` is the first projected pose in collision (costmap frame), ``time`` [s] how far
    ahead it is (0: the robot is in collision now), ``cost`` its footprint/cell cost.
    """

    def __init__(self, message: str, pose: tuple[float, float, float], time: float,
                 cost: int) -> None:
        super().__init__(message)
        self.pose = pose
        self.time = time
        self.cost = cost


class CostmapTooSmall(NoValidControl):
    """The robot pose lies outside the local costmap, so the cost regulation cannot read
    its cost (Nav2 ``ControllerException``: costmap too small for the robot footprint)."""

"""MPPI failure types (subclasses of :mod:`navstack.core.errors` controller errors)."""

from __future__ import annotations

from navstack.core.errors import InvalidPath, NoValidControl


class OptimizerFailed(NoValidControl):
    """Every sampled trajectory collided in every attempt (Nav2 ``Optimizer::fallback``
    raising ``NoValidControl("Optimizer fail to compute path")``).

    ``critic`` names the collision critic that flagged all samples; ``attempts`` is the
    number of optimizations tried (``retry_attempt_limit + 1``).
    """

    def __init__(self, batch_size: int, critic: str, attempts: int) -> None:
        self.batch_size = batch_size
        self.critic = critic
        self.attempts = attempts
        super().__init__(
            f"MPPI optimizer failed to compute a path: all {batch_size} sampled "
            f"trajectories collide ({critic}) in {attempts} attempt(s); the robot is boxed "
            f"in or already in collision - clear the costmap or run a recovery behavior")


class MPPIInvalidPath(InvalidPath):
    """The plan is empty, in another frame than the costmap, or has no pose inside the
    costmap near the robot (Nav2 ``PathHandler`` raising ``nav2_core::InvalidPath``);
    the fix is a new plan from the planner or transforming pose and plan into the
    costmap frame."""

"""DWB failure types (subclasses of :mod:`navstack.core.errors` controller errors)."""

from __future__ import annotations

from navstack.core.errors import InvalidPath, NoValidControl


class NoLegalTrajectories(NoValidControl):
    """Every velocity sample was rejected (``dwb_core::NoLegalTrajectoriesException``).

    ``rejections`` maps ``(critic name, reason)`` to the number of samples that critic
    rejected first; the message lists them, largest first, e.g. ``"no valid trajectory:
    all 420 samples rejected: 300 by BaseObstacle (collision), 120 by PathDist
    (unreachable area)"``.
    """

    def __init__(self, num_samples: int, rejections: dict[tuple[str, str], int],
                 notes: tuple[str, ...] = ()) -> None:
        self.num_samples = num_samples
        self.rejections = dict(rejections)
        self.notes = notes
        if num_samples == 0:
            text = ("no valid trajectory: the velocity sampler produced no samples; check "
                    "max_vel_x/max_vel_y/max_vel_theta/max_speed_xy and the speed limit")
        else:
            parts = [f"{n} by {critic} ({reason})" for (critic, reason), n in
                     sorted(self.rejections.items(), key=lambda kv: (-kv[1], kv[0]))]
            text = f"no valid trajectory: all {num_samples} samples rejected: " + ", ".join(parts)
        if notes:
            text += "; " + "; ".join(notes)
        super().__init__(text)


class InvalidPlan(InvalidPath):
    """The plan given to the controller is empty or has no pose near the robot.

    Nav2 raises ``nav2_core::InvalidPath`` in the same situations; the fix is a new plan
    from the planner (or a pose/plan in the costmap frame).
    """

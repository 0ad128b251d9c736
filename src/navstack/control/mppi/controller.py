"""``MPPIController``: Nav2's ``nav2_mppi_controller::MPPIController`` for navstack.

The controller contract (:mod:`navstack.control`): construct with
``MPPIController(params, footprint=...)``, then each cycle call
``compute(pose, velocity, path, costmap, now) -> Twist2D`` with pose and path in the
costmap's frame.  Per cycle it

1. takes the plan (a new plan acts as ``setPlan``) and prunes it around the robot
   (:class:`~navstack.control.mppi.path_handler.PathHandler`);
2. runs the optimizer (:class:`~navstack.control.mppi.optimizer.Optimizer`) on the
   costmap and returns the first command of the optimal control sequence.

Nothing is published here; for visualisation the controller exposes
:attr:`optimal_trajectory` ``(T, 3)``, :attr:`generated_trajectories` ``(B, T, 3)``,
:meth:`visualization_trajectories` (down-sampled by ``TrajectoryVisualizer``) and
:attr:`transformed_plan`.  Failures raise :class:`~navstack.core.errors.NoValidControl`
(:class:`~navstack.control.mppi.errors.OptimizerFailed`) or
:class:`~navstack.core.errors.InvalidPath`
(:class:`~navstack.control.mppi.errors.MPPIInvalidPath`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.control.mppi.critics import RobotShape
from navstack.control.mppi.errors import MPPIInvalidPath
from navstack.control.mppi.optimizer import Optimizer
from navstack.control.mppi.params import MPPIParams
from navstack.control.mppi.path_handler import PathHandler
from navstack.core.errors import InvalidMessage
from navstack.core.interfaces import Controller
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.plugins import register_controller
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D

FloatArray = NDArray[np.float64]


@register_controller("MPPI", nav2="nav2_mppi_controller::MPPIController")
class MPPIController(Controller):
    """Model Predictive Path Integral controller (Nav2 semantics, numba kernels).

    ``params`` is an :class:`MPPIParams` or a Nav2-layout mapping (the ``FollowPath``
    section without ``plugin``); ``footprint`` gives the robot outline for
    ``consider_footprint`` and the inscribed radius the ObstaclesCritic needs (a point
    robot without it).
    """

    params_model = MPPIParams
    params: MPPIParams

    def __init__(self, params: MPPIParams | Mapping[str, Any] | None = None, *,
                 footprint: Footprint | None = None) -> None:
        super().__init__(params if isinstance(params, MPPIParams)
                         else MPPIParams.from_mapping(params), footprint=footprint)
        self.optimizer = Optimizer(self.params, RobotShape.from_footprint(footprint))
        self.path_handler = PathHandler(self.params)
        self._plan_msg: Path | None = None
        self.transformed_plan = np.zeros((0, 3))

    # --- contract ------------------------------------------------------------------------
    def set_plan(self, path: Path) -> None:
        """Take a new plan (``setPlan``); the optimizer keeps its warm start."""
        self._plan_msg = path
        self.path_handler.set_path(path.as_array())

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2 speed limit: 0 = none; ``percentage`` of the maxima or absolute [m/s]."""
        self.optimizer.set_speed_limit(limit, percentage)

    def reset(self) -> None:
        """Forget the warm-start control sequence (new goal); speed limits stay."""
        self.optimizer.reset(reset_speed_limits=False)

    def compute(self, pose: Pose2D, velocity: Twist2D, path: Path | None,
                costmap: Costmap2D, now: float = 0.0) -> Twist2D:
        """Velocity command for this cycle (``computeVelocityCommands``).

        ``pose``/``path`` in the costmap frame; ``velocity`` the measured body twist.
        A ``path`` other than the current plan acts as :meth:`set_plan`; ``None`` keeps
        the current plan.  ``now`` is accepted for the contract (MPPI is time-invariant).
        """
        for v, what in ((pose.x, "pose.x"), (pose.y, "pose.y"), (pose.theta, "pose.theta")):
            if not math.isfinite(v):
                raise InvalidMessage(f"MPPI compute: {what} is {v}; pose must be finite")
        if not velocity.is_finite():
            raise InvalidMessage(f"MPPI compute: velocity {velocity} is not finite")
        self._accept_plan(path, costmap)
        xyt = (pose.x, pose.y, pose.theta)
        goal = self.path_handler.goal()
        local = self.path_handler.transform_path(xyt, costmap)
        self.transformed_plan = local
        cmd = self.optimizer.evaluate(xyt, (velocity.vx, velocity.vy, velocity.wz), local,
                                      goal, costmap)
        return Twist2D(float(cmd[0]), float(cmd[1]), float(cmd[2]))

    def _accept_plan(self, path: Path | None, costmap: Costmap2D) -> None:
        if path is not None and path is not self._plan_msg:
            self.set_plan(path)
        if self._plan_msg is None:
            raise MPPIInvalidPath("no plan: pass a path to compute() or call set_plan() first")
        frame = self._plan_msg.header.frame_id
        if frame and costmap.frame_id and frame != costmap.frame_id:
            raise MPPIInvalidPath(
                f"plan is in frame '{frame}' but the costmap is in '{costmap.frame_id}'; "
                f"transform the plan (and pose) into '{costmap.frame_id}' before compute()")

    # --- visualisation -----------------------------------------------------------------
    @property
    def optimal_trajectory(self) -> FloatArray:
        """``(T, 3)`` poses (x, y, yaw) of the optimal control sequence of the last cycle."""
        return self.optimizer.optimal_trajectory

    @property
    def generated_trajectories(self) -> NDArray[np.float32]:
        """``(B, T, 3)`` sampled trajectories of the last iteration (a float32 view)."""
        return self.optimizer.trajectories.transpose(2, 1, 0)

    @property
    def weights(self) -> FloatArray:
        """``(B,)`` softmax weights of the samples in the last update (sum to 1)."""
        return self.optimizer.weights

    def visualization_trajectories(self) -> NDArray[np.float32]:
        """Candidate trajectories down-sampled as Nav2's ``TrajectoryVisualizer``
        (every ``trajectory_step``-th sample, every ``time_step``-th pose)."""
        tv = self.params.TrajectoryVisualizer
        return self.generated_trajectories[::tv.trajectory_step, ::tv.time_step]


MPPI = MPPIController
"""Short alias."""

"""DWB local controller with Nav2 ``dwb_core`` / ``dwb_plugins`` / ``dwb_critics`` semantics.

``DWBLocalPlanner(params).compute(pose, velocity, path, costmap, now) -> Twist2D``; every
velocity sample of the dynamic window is simulated and scored at once with numpy/numba.
"""

from navstack.control.dwb.critics import CRITICS, CriticContext, TrajectoryCritic
from navstack.control.dwb.dwb_controller import DWBController, DWBEvaluation, DWBLocalPlanner
from navstack.control.dwb.errors import InvalidPlan, NoLegalTrajectories
from navstack.control.dwb.params import (
    DEFAULT_CRITICS,
    DWBParams,
    KinematicParameters,
    TrajectoryGeneratorParams,
)
from navstack.control.dwb.trajectory_generator import (
    TRAJECTORY_GENERATORS,
    LimitedAccelGenerator,
    StandardTrajectoryGenerator,
    TrajectoryBatch,
)

__all__ = [
    "CRITICS", "DEFAULT_CRITICS", "TRAJECTORY_GENERATORS", "CriticContext", "DWBController",
    "DWBEvaluation", "DWBLocalPlanner", "DWBParams", "InvalidPlan", "KinematicParameters",
    "LimitedAccelGenerator", "NoLegalTrajectories", "StandardTrajectoryGenerator",
    "TrajectoryBatch", "TrajectoryCritic", "TrajectoryGeneratorParams",
]

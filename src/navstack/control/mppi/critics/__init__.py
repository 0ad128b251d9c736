"""MPPI critics (Nav2 ``mppi::critics``), one scoring term each.

* :mod:`~navstack.control.mppi.critics.velocity` — Constraint, PreferForward,
  Twirling, VelocityDeadband;
* :mod:`~navstack.control.mppi.critics.goal` — Goal, GoalAngle;
* :mod:`~navstack.control.mppi.critics.collision` — Cost, Obstacles;
* :mod:`~navstack.control.mppi.critics.path` — PathAlign, PathFollow, PathAngle.

Each critic registers itself in :data:`CRITICS` with
:func:`~navstack.control.mppi.critics.base.register_critic`, its parameter model next to
it; importing this package registers the built-in ones.  :func:`load_critics` builds
the ``critics`` list of a controller's parameters, in order (Nav2
``CriticManager::loadCritics``); disabled critics are kept but score nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navstack.control.mppi.critics.base import (
    CRITICS,
    Critic,
    CriticData,
    CriticParams,
    RobotShape,
    WeightedCriticParams,
    register_critic,
)
from navstack.control.mppi.critics.collision import CostCritic, ObstaclesCritic
from navstack.control.mppi.critics.goal import GoalAngleCritic, GoalCritic
from navstack.control.mppi.critics.path import (
    PathAlignCritic,
    PathAngleCritic,
    PathFollowCritic,
)
from navstack.control.mppi.critics.velocity import (
    ConstraintCritic,
    PreferForwardCritic,
    TwirlingCritic,
    VelocityDeadbandCritic,
)
from navstack.control.mppi.models import MotionModel

if TYPE_CHECKING:
    from navstack.control.mppi.params import MPPIParams


def load_critics(params: MPPIParams, model: MotionModel, shape: RobotShape) -> list[Critic]:
    """The critics named in ``params.critics``, configured from their sections."""
    return [CRITICS.get(name)(params.critic(name), params, model, shape)
            for name in params.critics]


__all__ = [
    "CRITICS",
    "ConstraintCritic",
    "CostCritic",
    "Critic",
    "CriticData",
    "CriticParams",
    "GoalAngleCritic",
    "GoalCritic",
    "ObstaclesCritic",
    "PathAlignCritic",
    "PathAngleCritic",
    "PathFollowCritic",
    "PreferForwardCritic",
    "RobotShape",
    "TwirlingCritic",
    "VelocityDeadbandCritic",
    "WeightedCriticParams",
    "load_critics",
    "register_critic",
]

"""All DWB critics, registered in :data:`CRITICS` under their Nav2 names.

==================  =====================================================  =============
name                what it scores / rejects                               default scale
==================  =====================================================  =============
RotateToGoal        near the goal: brake, then rotate to the goal yaw      32
Oscillation         rejects re-reversing an axis right after a flip        1
BaseObstacle        centre-cell cost; rejects lethal/inscribed/unknown     0.02
ObstacleFootprint   footprint-outline cost; rejects lethal/unknown         0.02
GoalAlign           nose distance to the (shifted) local goal             24
PathAlign           nose distance to the plan                              32
PathDist            end distance to the plan; rejects unreachable cells    32
GoalDist            end distance to the local goal                         24
PreferForward       penalises reversing/strafing, then ``|wz|``            1
Twirling            ``|wz|``                                               0 (off)
RotateBeforeStart   navstack: rotate toward the path before starting       32
==================  =====================================================  =============
"""

from __future__ import annotations

from navstack.control.dwb.critic_base import (
    CRITICS,
    CriticContext,
    CriticParams,
    TrajectoryCritic,
    register_critic,
    resolve_critic,
)
from navstack.control.dwb.critics_map_grid import (
    AlignParams,
    GoalAlignCritic,
    GoalDistCritic,
    MapGridCritic,
    MapGridParams,
    PathAlignCritic,
    PathDistCritic,
)
from navstack.control.dwb.critics_motion import (
    OscillationCritic,
    OscillationParams,
    PreferForwardCritic,
    PreferForwardParams,
    RotateBeforeStartCritic,
    RotateBeforeStartParams,
    RotateToGoalCritic,
    RotateToGoalParams,
    TwirlingCritic,
)
from navstack.control.dwb.critics_obstacle import (
    BaseObstacleCritic,
    ObstacleFootprintCritic,
    ObstacleParams,
)

__all__ = [
    "CRITICS", "AlignParams", "BaseObstacleCritic", "CriticContext", "CriticParams",
    "GoalAlignCritic", "GoalDistCritic", "MapGridCritic", "MapGridParams",
    "ObstacleFootprintCritic", "ObstacleParams", "OscillationCritic", "OscillationParams",
    "PathAlignCritic", "PathDistCritic", "PreferForwardCritic", "PreferForwardParams",
    "RotateBeforeStartCritic", "RotateBeforeStartParams", "RotateToGoalCritic",
    "RotateToGoalParams", "TrajectoryCritic", "TwirlingCritic", "register_critic",
    "resolve_critic",
]

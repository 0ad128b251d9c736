"""Missions: behaviour trees that orchestrate navigation goals (docs/missions.md).

* :class:`MissionContext` -- the mission's handle on the robot (bus actions, TF, record);
* behaviours: :class:`NavigateToPose`, :class:`FollowWaypoints`, :class:`Spin`,
  :class:`LookAround`, :class:`WaitFor`, :class:`RememberHome`, :class:`ReturnHome`,
  :class:`SaveMap`, and the exploration / coverage / mapping ones;
* :class:`Mission`, :class:`MissionRunner` -- run a tree, publish ``/mission/state``, end
  SUCCEEDED / FAILED / CANCELED with a reason;
* built-in missions: :func:`explore_mission`, :func:`coverage_mission`,
  :func:`map_poses_mission`.
"""

from navstack.missions.behaviours import (
    FollowWaypoints,
    LookAround,
    NavigateToPose,
    RememberHome,
    ReturnHome,
    SaveMap,
    Spin,
    WaitFor,
)
from navstack.missions.context import MissionContext
from navstack.missions.coverage import CoverageParams, coverage_mission
from navstack.missions.explore import Escape, Explore, explore_mission
from navstack.missions.map_poses import map_poses_mission
from navstack.missions.mission import Mission, MissionResult, MissionRunner, MissionStatus

__all__ = ["CoverageParams", "Escape", "Explore", "FollowWaypoints", "LookAround", "Mission",
           "MissionContext", "MissionResult", "MissionRunner", "MissionStatus",
           "NavigateToPose", "RememberHome", "ReturnHome", "SaveMap", "Spin", "WaitFor",
           "coverage_mission", "explore_mission", "map_poses_mission"]

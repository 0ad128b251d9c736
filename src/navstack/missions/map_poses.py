"""Map a world by visiting chosen poses (the Nav2 lab), as a mission.

With SLAM running, the robot visits a list of named poses in order (optionally turning a
full circle at each, for a forward-looking sensor), then the map is saved through
slam_toolbox's services: the map_server files (YAML + PGM) and the serialized pose graph,
which ``map_server`` and SLAM's localization mode reload.  A pose that cannot be reached
is recorded and skipped (the map may still be complete); the mission fails only if the
map cannot be saved.  The caller scores the map -- completeness against the world's true
free space after each pose, so a user can find the fewest poses that give a full map.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from py_trees.common import Status
from py_trees.composites import Sequence as SequenceNode

from navstack.core.msgs import Pose2D
from navstack.missions.behaviours import (
    LookAround,
    MissionBehaviour,
    NavigateToPose,
    RememberHome,
    ReturnHome,
    SaveMap,
)
from navstack.missions.context import MissionContext
from navstack.missions.explore import wait_for_map
from navstack.missions.mission import Mission

__all__ = ["PoseVisit", "VisitPoses", "map_poses_mission"]


@dataclass
class PoseVisit:
    name: str
    pose: Pose2D
    status: str = "PENDING"
    reason: str = ""
    time: float = 0.0


class VisitPoses(MissionBehaviour):
    """Visit ``poses`` in order; failures are recorded and skipped (module docstring)."""

    def __init__(self, ctx: MissionContext, poses: Sequence[tuple[str, Pose2D]],
                 look_around: bool = False, name: str = "VisitPoses") -> None:
        super().__init__(ctx, name)
        self.visits = [PoseVisit(n, p) for n, p in poses]
        self.look_around = look_around
        self.index = 0
        self.nav = NavigateToPose(ctx, self._pose, name="VisitPose")
        self.spin = LookAround(ctx)
        self.phase = "nav"

    def _pose(self) -> Pose2D | None:
        return self.visits[self.index].pose if self.index < len(self.visits) else None

    def initialise(self) -> None:
        self.index = 0
        self.phase = "nav"
        for v in self.visits:
            v.status, v.reason = "PENDING", ""

    def update(self) -> Status:
        if self.index >= len(self.visits):
            return Status.SUCCESS
        v = self.visits[self.index]
        node = self.nav if self.phase == "nav" else self.spin
        node.tick_once()
        if node.status is Status.RUNNING:
            self.ctx.feedback(f"{self.name}: {v.name} ({self.index + 1}/{len(self.visits)})",
                              pose=self.index)
            return Status.RUNNING
        if node.status is Status.FAILURE:
            v.status, v.reason = "FAILED", self.ctx.failures.pop().reason
            self.ctx.log(f"{self.name}: {v.name} not reached: {v.reason}")
        elif self.phase == "nav" and self.look_around:
            self.phase = "spin"
            self.nav.stop(Status.INVALID)
            return Status.RUNNING
        else:
            v.status = "REACHED"
            self.ctx.log(f"{self.name}: reached {v.name}")
        v.time = self.ctx.now
        self.nav.stop(Status.INVALID)
        self.spin.stop(Status.INVALID)
        self.phase = "nav"
        self.index += 1
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID:
            self.nav.stop(Status.INVALID)
            self.spin.stop(Status.INVALID)


def map_poses_mission(ctx: MissionContext, poses: Sequence[tuple[str, Pose2D]],
                      save_path: str, look_around: bool = False,
                      return_home: bool = False, home_tolerance: float = 0.3) -> Mission:
    """Visit ``poses`` with SLAM and save the map to ``save_path`` (module docstring)."""
    visit = VisitPoses(ctx, poses, look_around)
    steps: list[Any] = [
        wait_for_map(ctx), RememberHome(ctx), visit]
    if return_home:
        steps.append(ReturnHome(ctx, tolerance=home_tolerance))
    steps.append(SaveMap(ctx, save_path))
    root = SequenceNode("map_poses", memory=True, children=steps)

    def summary() -> dict[str, Any]:
        return {"map_poses": {
            "poses": [{"name": v.name, "pose": [v.pose.x, v.pose.y, v.pose.theta],
                       "status": v.status, "reason": v.reason, "time": round(v.time, 2)}
                      for v in visit.visits],
            "saved": ctx.results.get("saved_map", {})}}

    return Mission("map-poses", root, ctx, "map the world by visiting chosen poses", summary)

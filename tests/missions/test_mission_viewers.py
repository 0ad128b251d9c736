"""The web dashboard and Foxglove show a running exploration: the mission state and the
frontier markers."""

from __future__ import annotations

import json
from pathlib import Path

from navstack.core.msgs import MarkerArray
from navstack.interfaces.foxglove_live import frontier_scene
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.mission_catalog import MissionOptions
from navstack.interfaces.mission_run import start_mission
from navstack.interfaces.web.commands import NavCommander
from navstack.interfaces.web.model import DashboardModel
from navstack.missions.explore import FRONTIERS_TOPIC
from navstack.runtime.bus import QoS
from tests.interfaces.test_foxglove_live import protobuf_fields


def test_dashboard_frame_and_foxglove_scene_show_the_exploration(tmp_path: Path) -> None:
    run = start_mission("explore", tmp_path, "arena", "turtlebot3_waffle_pi", 1,
                        MissionOptions(max_duration=200.0))
    stack = run.stack
    markers: list[MarkerArray] = []
    stack.runtime.bus.subscribe(FRONTIERS_TOPIC, MarkerArray, markers.append, QoS(depth=5))
    runner = LiveRunner(stack, real_time_factor=None)
    model = DashboardModel(runner, NavCommander(stack), frame_rate=1000.0)
    model.attach()
    runner.start_in_caller()
    run.runner.start()
    stack.run_for(4.0)
    state = json.loads(model.frame[1])
    mission = state["mission"]
    assert mission["name"] == "explore" and mission["status"] == "RUNNING"
    assert mission["feedback"].startswith("Explore: ")
    assert state["frontiers"]["points"] and state["frontiers"]["goals"]
    # the markers are explore_lite's: POINTS per frontier (blue) and a SPHERE per goal
    last = markers[-1]
    kinds = {(m.ns, m.type) for m in last.markers if m.action == m.ADD}
    assert ("frontiers", 8) in kinds and ("frontiers", 2) in kinds
    # foxglove.SceneUpdate: entities = field 2; SceneEntity: frame_id 2, id 3, cubes 8,
    # spheres 9
    update = protobuf_fields(frontier_scene(last, stack.now).encode())
    entity = protobuf_fields(update[2][0])
    assert entity[2] == [b"map"] and entity[3] == [b"frontiers"]
    assert len(entity[8]) == sum(len(m.points) for m in last.markers if m.type == 8)
    assert len(entity[9]) == sum(1 for m in last.markers if m.type == 2 and m.action == m.ADD)
    while not run.runner.done:
        stack.run_for(2.0)
    stack.run_for(0.5)
    final = json.loads(model.frame[1])["mission"]
    assert final["status"] == "SUCCEEDED"
    model.detach()
    runner.stop()
    run.close()

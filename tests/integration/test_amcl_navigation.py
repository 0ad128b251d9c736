"""Navigation on AMCL instead of the simulator's perfect localization (issue 5)."""

from __future__ import annotations

import math

import pytest

from navstack.core.errors import ConfigError
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.demo import default_waypoints_path
from navstack.interfaces.stack import NavStack
from navstack.interfaces.stack_description import AmclLocalization
from navstack.navigation.waypoint_follower import load_waypoints


def test_a_goal_is_reached_while_amcl_tracks_the_true_pose() -> None:
    stack = NavStack("office", "diff_drive", seed=1, localization="amcl").start()
    assert stack.amcl is not None and stack.map_server is not None
    nav = Navigator(stack)
    errors: list[float] = []

    def sample() -> None:
        est = stack.runtime.tf.lookup_pose2d("map", "base_link")
        true = stack.sim.sim.pose
        errors.append(math.hypot(est.x - true.x, est.y - true.y))

    stack.runtime.scheduler.create_timer(1.0, sample, first_at=stack.now + 1.0)
    goal = dict(load_waypoints(default_waypoints_path()))["Goal_3"]
    assert nav.goToPose(goal)
    while not nav.isTaskComplete():
        pass
    assert nav.getResult() == TaskResult.SUCCEEDED
    assert stack.amcl.updates > 10
    assert len(errors) > 20
    rms = math.sqrt(sum(e * e for e in errors) / len(errors))
    print(f"AMCL error rms {rms:.4f} max {max(errors):.4f} over {len(errors)} samples")
    assert rms < 0.05
    assert max(errors) < 0.25
    assert stack.sim.sim.collisions == 0


def test_a_bad_amcl_key_names_it() -> None:
    with pytest.raises(ConfigError, match=r"amcl\.max_particle"):
        NavStack("office", "diff_drive", localization=AmclLocalization({"max_particle": 100}))

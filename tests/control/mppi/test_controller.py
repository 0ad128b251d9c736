"""The controller contract: failures, speed limits, visualisation outputs, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.mppi import MPPIController, MPPIInvalidPath, OptimizerFailed
from navstack.core.errors import InvalidMessage, InvalidPath, NoValidControl
from navstack.core.msgs import Path, Pose2D, Twist2D
from tests.control.mppi.helpers import add_box, costmap, drive, straight_plan


def _path(frame: str = "odom") -> Path:
    return Path.from_array(straight_plan(3.0), frame_id=frame)


def test_boxed_in_robot_gets_no_valid_control_after_the_retries() -> None:
    cm = costmap()
    add_box(cm, -1.0, -1.0, 1.0, 1.0)  # the robot sits inside an obstacle
    ctrl = MPPIController({"batch_size": 200})
    with pytest.raises(NoValidControl) as err:
        ctrl.compute(Pose2D(), Twist2D(), _path(), cm)
    assert isinstance(err.value, OptimizerFailed)
    assert str(err.value) == (
        "MPPI optimizer failed to compute a path: all 200 sampled trajectories collide "
        "(CostCritic) in 2 attempt(s); the robot is boxed in or already in collision - "
        "clear the costmap or run a recovery behavior")
    ctrl = MPPIController({"batch_size": 200, "retry_attempt_limit": 0,
                           "critics": ["ObstaclesCritic", "GoalCritic"]})
    with pytest.raises(OptimizerFailed) as err2:
        ctrl.compute(Pose2D(), Twist2D(), _path(), cm)
    assert (err2.value.attempts, err2.value.critic) == (1, "ObstaclesCritic")


def test_invalid_plans() -> None:
    cm = costmap()
    ctrl = MPPIController({"batch_size": 100})
    with pytest.raises(InvalidPath, match="no plan: pass a path"):
        ctrl.compute(Pose2D(), Twist2D(), None, cm)
    with pytest.raises(MPPIInvalidPath) as err:
        ctrl.compute(Pose2D(), Twist2D(), _path("map"), cm)
    assert str(err.value) == ("plan is in frame 'map' but the costmap is in 'odom'; transform "
                              "the plan (and pose) into 'odom' before compute()")
    far = Path.from_array(straight_plan(1.0) + np.array([10.0, 0.0, 0.0]), frame_id="odom")
    with pytest.raises(MPPIInvalidPath, match="lies inside the costmap"):
        ctrl.compute(Pose2D(), Twist2D(), far, cm)
    with pytest.raises(InvalidMessage, match=r"pose\.x is nan"):
        ctrl.compute(Pose2D(math.nan, 0.0, 0.0), Twist2D(), _path(), cm)


def test_speed_limits_scale_the_command() -> None:
    cm = costmap()
    for limit, percentage, top in ((50.0, True, 0.25), (0.2, False, 0.2)):
        ctrl = MPPIController({"batch_size": 300})
        ctrl.set_speed_limit(limit, percentage)
        run = drive(ctrl, straight_plan(3.0), cm, dt=0.05, max_time=4.0)
        fastest = max(c.vx for c in run.commands)
        assert top - 0.05 < fastest <= top + 1e-9
        assert max(abs(c.wz) for c in run.commands) <= 1.9 * top / 0.5 + 1e-9
        ctrl.set_speed_limit(0.0, True)
        assert ctrl.optimizer.limits == (-0.35, 0.5, 0.5, 1.9)


def test_visualisation_outputs_and_reset() -> None:
    ctrl = MPPIController({"batch_size": 100, "time_steps": 30})
    pose = Pose2D(0.2, 0.05, 0.1)
    ctrl.compute(pose, Twist2D(0.2, 0.0, 0.0), _path(), costmap())
    gen = ctrl.generated_trajectories
    assert gen.shape == (100, 30, 3) and gen.dtype == np.float32
    assert ctrl.visualization_trajectories().shape == (20, 10, 3)
    opt = ctrl.optimal_trajectory
    assert opt.shape == (30, 3)
    # the first pose is one model_dt of driving from the robot
    assert math.hypot(opt[0, 0] - pose.x, opt[0, 1] - pose.y) <= 0.5 * 0.05 + 1e-9
    assert math.isclose(float(ctrl.weights.sum()), 1.0, rel_tol=1e-12)
    assert ctrl.transformed_plan.shape[1] == 3
    assert np.any(ctrl.optimizer.control_sequence != 0.0)
    ctrl.reset()
    assert np.all(ctrl.optimizer.control_sequence == 0.0)


def test_same_seed_same_commands() -> None:
    def commands(regenerate: bool) -> list[Twist2D]:
        ctrl = MPPIController({"batch_size": 200, "seed": 7,
                               "regenerate_noises": regenerate})
        return drive(ctrl, straight_plan(3.0), costmap(), dt=0.05, max_time=1.0).commands
    for regenerate in (False, True):
        a, b = commands(regenerate), commands(regenerate)
        assert a == b and len(a) == 20
    assert commands(True) != commands(False)

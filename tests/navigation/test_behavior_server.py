"""BehaviorServer against a fake base that integrates /cmd_vel into TF odom->base_link."""

from __future__ import annotations

import math
from typing import Any

import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.navigation import messages as m
from navstack.navigation.behavior_server import (
    BehaviorResult,
    BehaviorServer,
    BehaviorServerParams,
    CollisionChecker,
)
from navstack.navigation.behaviors import Spin, SpinParams, Wait
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus
from navstack.runtime.node import Runtime
from tests.navigation.fakes import FakeBase


def setup(pose: Pose2D | None = None, checker: CollisionChecker | None = None
          ) -> tuple[Runtime, FakeBase, BehaviorServer]:
    rt = Runtime()
    base = FakeBase(rt, pose)
    server = BehaviorServer(rt, collision_checker=checker)
    rt.bring_up()
    return rt, base, server


def send(rt: Runtime, action: str, goal: Any, feedback: list[Any] | None = None
         ) -> GoalHandle[Any]:
    cb = feedback.append if feedback is not None else None
    return ActionClient(rt.bus, action).send_goal(goal, feedback_cb=cb)


def finish(rt: Runtime, h: GoalHandle[Any], settle: float = 0.1) -> None:
    rt.scheduler.run_until(60.0, until=lambda: h.done)
    rt.scheduler.run_for(settle)  # deliver the final zero Twist to the base


def stopped(base: FakeBase) -> bool:
    last = base.twists[-1][1]
    return last.linear.x == 0.0 and last.angular.z == 0.0


@pytest.mark.parametrize("target", [1.57, -1.0])
def test_spin_turns_the_tf_pose_by_the_target(target: float) -> None:
    rt, base, _ = setup(Pose2D(1.0, 2.0, 0.3))
    feedback: list[m.BehaviorFeedback] = []
    h = send(rt, m.SPIN, m.SpinGoal(target), feedback)
    finish(rt, h)
    assert h.status is GoalStatus.SUCCEEDED
    turned = math.remainder(base.pose.theta - 0.3, 2 * math.pi)
    # overshoot: at most one cycle at min_rotational_vel (0.4 rad/s / 20 Hz = 0.02 rad)
    # plus one base step of latency for the stop command (0.004 rad)
    assert turned == pytest.approx(target, abs=0.024)
    assert abs(turned) >= abs(target) - 1e-9
    assert (base.pose.x, base.pose.y) == (1.0, 2.0) and stopped(base)
    rates = [t.angular.z for _, t in base.twists[:-1]]
    assert rates[0] == pytest.approx(math.copysign(1.0, target))  # max_rotational_vel
    assert all(0.4 - 1e-12 <= abs(w) <= 1.0 + 1e-12 and w * target > 0 for w in rates)
    assert [abs(w) for w in rates] == sorted((abs(w) for w in rates), reverse=True)
    assert abs(feedback[-1].progress) == pytest.approx(abs(turned), abs=0.005)
    assert h.result is not None and isinstance(h.result.result, BehaviorResult)


def test_backup_drives_the_distance_backwards_and_stops() -> None:
    rt, base, _ = setup(Pose2D(0.0, 0.0, math.pi / 2))
    h = send(rt, m.BACKUP, m.BackUpGoal(distance=0.3, speed=0.1))
    finish(rt, h)
    assert h.status is GoalStatus.SUCCEEDED and h.result is not None
    assert base.pose.x == pytest.approx(0.0, abs=1e-9)
    # constant speed (Nav2): it stops at the first cycle that sees >= 0.3 m, so it passes
    # the target by less than one cycle of travel (0.1 m/s / 20 Hz) plus one base step
    assert -0.3 - 0.006 < base.pose.y <= -0.3
    assert h.result.result.total_elapsed_time == pytest.approx(3.05)
    assert {t.linear.x for _, t in base.twists[:-1]} == {-0.1} and stopped(base)


def test_drive_on_heading_and_sign_mismatch() -> None:
    rt, base, _ = setup(Pose2D(0.0, 0.0, math.pi / 2))
    h = send(rt, m.DRIVE_ON_HEADING, m.DriveOnHeadingGoal(distance=0.5, speed=0.25))
    finish(rt, h)
    assert h.status is GoalStatus.SUCCEEDED
    assert 0.5 <= base.pose.y < 0.5 + 0.25 / 20 + 0.0025
    bad = send(rt, m.DRIVE_ON_HEADING, m.DriveOnHeadingGoal(distance=0.5, speed=-0.25))
    assert bad.status is GoalStatus.FAILED and bad.result is not None
    assert bad.result.error_code == m.BehaviorErrorCode.INVALID_INPUT
    assert bad.result.error_msg == ("drive_on_heading: distance 0.5 m and speed -0.25 m/s have "
                                    "different signs; give both the sign of the direction of "
                                    "travel")


def test_time_allowance_exceeded_fails_with_timeout_and_stops() -> None:
    rt, base, _ = setup()
    h = send(rt, m.SPIN, m.SpinGoal(3.14, time_allowance=0.5))
    finish(rt, h)
    assert h.status is GoalStatus.FAILED and h.result is not None
    assert h.result.error_code == m.BehaviorErrorCode.TIMEOUT
    assert h.result.error_msg == ("spin: spinning 3.14 rad did not finish within "
                                  "time_allowance 0.5 s")
    assert h.result.result.total_elapsed_time == pytest.approx(0.55)
    assert stopped(base)


def test_collision_ahead_stops_before_the_obstacle() -> None:
    rt, base, _ = setup(checker=lambda p: p.x < -0.2)  # wall behind the robot at x = -0.2
    h = send(rt, m.BACKUP, m.BackUpGoal(distance=0.3, speed=0.05))
    finish(rt, h)
    assert h.status is GoalStatus.FAILED and h.result is not None
    assert h.result.error_code == m.BehaviorErrorCode.COLLISION_AHEAD
    # 2 s ahead at 0.05 m/s = 0.1 m: the hit is predicted once the robot passes x = -0.1
    assert -0.11 < base.pose.x < -0.1 and stopped(base)
    msg = h.result.error_msg
    assert msg.startswith("backup: collision ahead: backing up 0.30 m at 0.05 m/s would put "
                          "the footprint in collision at odom pose (x=-0.20, y=0.00, yaw=0.00) "
                          "within simulate_ahead_time 2 s; stopped at (x=-0.10, y=0.00")
    rt2, base2, _ = setup(checker=lambda p: p.theta > 1.0)
    h2 = send(rt2, m.SPIN, m.SpinGoal(1.57))
    finish(rt2, h2)
    assert h2.status is GoalStatus.FAILED and base2.pose.theta < 1.0


def test_projection_stops_where_the_behavior_ends() -> None:
    # the goal ends at x = -0.1, just short of the wall at -0.12: no false alarm
    rt, base, _ = setup(checker=lambda p: p.x < -0.12)
    h = send(rt, m.BACKUP, m.BackUpGoal(distance=0.1, speed=0.05))
    finish(rt, h)
    assert h.status is GoalStatus.SUCCEEDED
    assert -0.1 - 0.0025 - 0.0005 < base.pose.x <= -0.1


def test_wait_cancel_preempt_tf_error_and_inactive() -> None:
    rt, base, server = setup()
    feedback: list[m.BehaviorFeedback] = []
    h = send(rt, m.WAIT, m.WaitGoal(1.0), feedback)
    finish(rt, h)
    assert h.status is GoalStatus.SUCCEEDED and stopped(base)
    assert h.result is not None and h.result.result.total_elapsed_time == pytest.approx(1.0)
    assert feedback[0].progress == pytest.approx(1.0) and feedback[-1].progress == 0.0

    spin = send(rt, m.SPIN, m.SpinGoal(3.0))
    rt.scheduler.run_for(0.5)
    backup = send(rt, m.BACKUP, m.BackUpGoal(0.1, 0.1))
    assert spin.status is GoalStatus.CANCELED and spin.result is not None
    assert spin.result.error_msg == "preempted by a new goal"
    assert server.active_behavior == "backup"
    rt.scheduler.run_for(0.3)
    backup.cancel()
    assert backup.status is GoalStatus.CANCELED and server.active_behavior is None
    rt.scheduler.run_for(0.1)
    assert stopped(base)

    server.deactivate()
    rejected = send(rt, m.SPIN, m.SpinGoal(1.0))
    assert rejected.status is GoalStatus.REJECTED and rejected.result is not None
    assert rejected.result.error_msg == ("behavior_server is not active (state INACTIVE); "
                                         "activate it first")

    rt2 = Runtime()
    BehaviorServer(rt2)
    rt2.bring_up()
    no_tf = send(rt2, m.SPIN, m.SpinGoal(1.0))
    assert no_tf.status is GoalStatus.FAILED and no_tf.result is not None
    assert no_tf.result.error_code == m.BehaviorErrorCode.TF_ERROR
    assert no_tf.result.error_msg.startswith("spin: robot pose (base_link in odom) is not "
                                             "available: frame 'odom' does not exist")


def test_behavior_plugins_from_a_nav2_section() -> None:
    """``behavior_plugins`` picks the actions; a section names the type and may override
    the server-level Spin limits (Nav2 layout)."""
    params = BehaviorServerParams.from_mapping({
        "behavior_plugins": ["spin", "nap"], "max_rotational_vel": 0.8,
        "spin": {"plugin": "nav2_behaviors/Spin", "min_rotational_vel": 0.5},
        "nap": {"plugin": "nav2_behaviors::Wait"}}, file="nav2.yaml", key_path="behavior_server")
    spin = params.behaviors["spin"].params
    assert isinstance(spin, SpinParams)
    assert (spin.max_rotational_vel, spin.min_rotational_vel) == (0.8, 0.5)
    rt = Runtime()
    FakeBase(rt, Pose2D())
    server = BehaviorServer(rt, params)
    rt.bring_up()
    assert isinstance(server.behaviors["nap"], Wait) and isinstance(server.behaviors["spin"], Spin)
    h = send(rt, "/nap", m.WaitGoal(0.5))
    finish(rt, h)
    assert h.status is GoalStatus.SUCCEEDED
    assert h.result is not None and h.result.result.total_elapsed_time == pytest.approx(0.5)
    # only the listed behaviors are served
    assert set(rt.bus.action_servers) >= {"/spin", "/nap"} and m.BACKUP not in rt.bus.action_servers
    h = send(rt, "/nap", m.SpinGoal(1.0))  # the wrong goal type is an INVALID_INPUT failure
    finish(rt, h)
    assert h.status is GoalStatus.FAILED and h.result is not None
    assert h.result.error_code == int(m.BehaviorErrorCode.INVALID_INPUT)
    assert h.result.error_msg == "nap: expects a WaitGoal, got SpinGoal"


def test_behavior_section_errors_name_the_file_and_key() -> None:
    with pytest.raises(ConfigError) as err:
        BehaviorServerParams.from_mapping({"spin": {"plugin": "nav2_behaviors/Spinn"}},
                                          file="nav2.yaml", key_path="behavior_server")
    assert str(err.value).startswith("nav2.yaml: behavior_server.spin.plugin: unknown behavior "
                                     "plugin 'nav2_behaviors/Spinn' (did you mean "
                                     "'nav2_behaviors/Spin'?")
    with pytest.raises(ConfigError) as err:
        BehaviorServerParams.from_mapping({"behavior_plugins": ["dance"]}, file="nav2.yaml",
                                          key_path="behavior_server")
    assert str(err.value).startswith("nav2.yaml: behavior_server.dance.plugin: required key "
                                     "is missing")
    with pytest.raises(ConfigError) as err:
        BehaviorServerParams.from_mapping({"spin": {"max_rotational_vel": -1.0}},
                                          file="nav2.yaml", key_path="behavior_server")
    assert str(err.value) == ("nav2.yaml: behavior_server.spin.max_rotational_vel: Input should "
                              "be greater than 0 (got -1.0)")


def test_a_robot_already_in_collision_may_move_no_deeper() -> None:
    # a "wall" the robot overlaps by 0.05 m at y <= 0 whose depth grows as y falls:
    # backing up along it is allowed, turning into it is not
    def depth(p: Pose2D) -> float:
        return max(0.0, 0.05 - p.y + 0.1 * abs(p.theta))

    rt = Runtime()
    base = FakeBase(rt, Pose2D(0.0, 0.0, 0.0))
    server = BehaviorServer(rt, collision_checker=lambda p: depth(p) > 0.0,
                            penetration=depth)
    rt.bring_up()
    h = send(rt, m.BACKUP, m.BackUpGoal(distance=0.2, speed=0.1))
    finish(rt, h)
    assert h.status is GoalStatus.SUCCEEDED and base.pose.x == pytest.approx(-0.2, abs=0.01)
    h2 = send(rt, m.SPIN, m.SpinGoal(1.0))
    finish(rt, h2)
    assert h2.status is GoalStatus.FAILED and h2.result is not None
    assert h2.result.error_code == m.BehaviorErrorCode.COLLISION_AHEAD
    assert abs(base.pose.theta) < 0.1
    # without the penetration function the same robot may not move at all
    rt3 = Runtime()
    base3 = FakeBase(rt3, Pose2D(0.0, 0.0, 0.0))
    BehaviorServer(rt3, collision_checker=lambda p: depth(p) > 0.0)
    rt3.bring_up()
    h3 = send(rt3, m.BACKUP, m.BackUpGoal(distance=0.2, speed=0.1))
    finish(rt3, h3)
    assert h3.status is GoalStatus.FAILED and base3.pose.x > -0.01
    assert server.penetration is depth

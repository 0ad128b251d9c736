"""BtNavigator + default trees against scripted planner/controller/behavior servers.

The navigator ticks at 20 Hz from t = 0.05 s; the fake planner answers in the same
instant (before the next tick); the fake controller moves the base along the path at
1 m/s in 0.05 s steps.
"""

from __future__ import annotations

import math

import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D, PoseStamped
from navstack.navigation import messages as m
from navstack.navigation.bt_composites import recovery_running
from navstack.navigation.bt_navigator import BtNavigatorParams, NavigateResult
from navstack.navigation.trees import NavigateTreeParams
from navstack.runtime.actions import ActionClient, GoalStatus
from tests.navigation.fakes import make_harness

FAST = NavigateTreeParams(wait_duration=0.2)


def test_reaches_the_goal_with_one_plan_and_exact_feedback() -> None:
    h = make_harness(FAST)
    goal = h.goal(5.0, 0.0)
    res = h.run_until_done(goal)
    assert res.status is GoalStatus.SUCCEEDED
    assert res.result == NavigateResult(0, pytest.approx(5.15))
    assert h.base.pose.distance_to(Pose2D(5.0, 0.0)) < 1e-9
    assert len(h.planner.calls) == 1 and len(h.controller.goals) == 1
    assert h.planner.calls[0][1].goal.to_pose2d() == Pose2D(5.0, 0.0, 0.0)
    mid = next(f for f in h.feedback if f.navigation_time >= 2.0 - 1e-9)
    # straight path along x: remaining = 5 - x exactly; speed 1 m/s -> eta = remaining
    assert mid.distance_remaining == pytest.approx(5.0 - mid.current_pose.x, abs=1e-9)
    assert mid.estimated_time_remaining == pytest.approx(mid.distance_remaining, rel=1e-6)
    assert mid.number_of_recoveries == 0
    assert h.nav.active_goal is None and h.nav.tree is None


def test_replans_at_1hz_only_while_the_path_is_invalid() -> None:
    h = make_harness(FAST)
    h.behaviors.path_valid = lambda t: not 3.0 <= t < 6.0
    goal = h.goal(30.0, 0.0)
    h.rt.scheduler.run_until(9.0)
    assert goal.status is GoalStatus.EXECUTING
    # first plan at the first tick; the rate controller re-checks 1 s after each success
    # (checks at 1.10, 2.10 valid; 3.10 invalid -> plan, done at 3.15; 4.15 and 5.20
    # invalid -> plan; 6.25, 7.25, 8.25 valid again)
    times = [t for t, _ in h.planner.calls]
    assert times == pytest.approx([0.05, 3.10, 4.15, 5.20], abs=1e-9)
    assert h.behaviors.valid_checks == 8
    # every new path is handed to the running controller as a new goal, one tick later
    assert [t for t, _ in h.controller.goals] == pytest.approx([0.10, 3.15, 4.20, 5.25])


def test_goal_update_preempts_and_triggers_a_replan() -> None:
    h = make_harness(FAST)
    first = h.goal(10.0, 0.0)
    h.rt.scheduler.run_until(2.0)
    second = h.goal(2.0, 3.0)
    assert first.status is GoalStatus.CANCELED and first.result is not None
    assert first.result.error_msg == "preempted by a new goal"
    res = h.run_until_done(second)
    assert res.status is GoalStatus.SUCCEEDED
    t_replan, replan = h.planner.calls[1]
    assert t_replan == pytest.approx(2.10)  # next 1 Hz check after the 1.10 s one
    assert replan.goal.to_pose2d() == Pose2D(2.0, 3.0, 0.0)
    assert h.base.pose.distance_to(Pose2D(2.0, 3.0)) < 1e-9
    assert len(h.planner.calls) == 2


def test_controller_failure_runs_recoveries_in_round_robin_and_counts_them() -> None:
    h = make_harness(FAST, mode="fail")
    goal = h.goal(5.0, 0.0)
    res = h.run_until_done(goal)
    assert res.status is GoalStatus.FAILED
    assert res.error_code == m.NavigatorErrorCode.RECOVERIES_EXHAUSTED
    assert res.error_msg == ("could not reach the goal after 6 recoveries: FollowPath failed: "
                             "no valid trajectory: all 520 sampled trajectories collide "
                             "(NO_VALID_CONTROL)")
    assert isinstance(res.result, NavigateResult) and res.result.number_of_recoveries == 6
    recoveries = h.behaviors.names("clear_global", "spin", "wait", "backup")
    assert recoveries == ["clear_global", "spin", "wait", "backup", "clear_global", "spin"]
    # each subtree clear is local then global; each FollowPath failure first clears the
    # local costmap (context recovery) and retries once: 7 attempts x 2 goals
    assert h.behaviors.names("clear_local").count("clear_local") == 7 + 2
    assert len(h.controller.goals) == 14 and len(h.planner.calls) == 1
    counts = [f.number_of_recoveries for f in h.feedback]
    assert counts == sorted(counts) and counts[-1] == 6


def test_activity_says_what_a_running_goal_is_doing() -> None:
    """For whoever must stop a goal that has not ended (a benchmark's time limit)."""
    h = make_harness(NavigateTreeParams(wait_duration=30.0), mode="fail")
    assert h.nav.activity() == ""
    h.goal(5.0, 0.0)
    h.rt.scheduler.run_until(0.07)
    assert h.nav.activity() == "navigating (ComputePathToPose), 0 of 6 recoveries used"
    h.rt.scheduler.run_until(100.0, until=lambda: "wait" in h.behaviors.names())
    h.rt.scheduler.run_until(h.rt.now + 1.0)
    assert h.nav.activity() == (
        "recovering (Wait), 3 of 6 recoveries used; last failure: FollowPath failed: no "
        "valid trajectory: all 520 sampled trajectories collide (NO_VALID_CONTROL)")
    moving = make_harness(speed=0.5)
    moving.goal(5.0, 0.0)
    moving.rt.scheduler.run_until(1.0)
    assert moving.nav.activity() == "navigating (FollowPath), 0 of 6 recoveries used"


def test_recovery_behaviors_choose_the_round_robin_for_a_car() -> None:
    """An Ackermann robot cannot spin: its list leaves Spin out and keeps the order."""
    h = make_harness(FAST.model_copy(update={"recovery_behaviors": ("clear_costmaps", "wait",
                                                                   "backup")}), mode="fail")
    res = h.run_until_done(h.goal(5.0, 0.0))
    assert res.status is GoalStatus.FAILED
    assert h.behaviors.names("clear_global", "spin", "wait", "backup") == [
        "clear_global", "wait", "backup", "clear_global", "wait", "backup"]


def test_recovery_behaviors_are_validated() -> None:
    with pytest.raises(ConfigError, match="recovery_behaviors") as err:
        NavigateTreeParams.from_mapping({"recovery_behaviors": ["spin", "turn"]}, file="p.yaml",
                                        key_path="bt_navigator.tree")
    assert "'clear_costmaps', 'spin', 'wait' or 'backup'" in str(err.value)
    with pytest.raises(ConfigError, match="lists a behavior twice"):
        NavigateTreeParams.from_mapping({"recovery_behaviors": ["wait", "wait"]})
    with pytest.raises(ConfigError, match="recovery_behaviors"):
        NavigateTreeParams.from_mapping({"recovery_behaviors": []})


def test_new_goal_during_a_recovery_halts_it_and_navigates_to_the_new_goal() -> None:
    h = make_harness(NavigateTreeParams(wait_duration=5.0), mode="fail")
    first = h.goal(5.0, 0.0)
    h.rt.scheduler.run_until(60.0, until=lambda: "wait" in h.behaviors.names())
    t_wait = h.rt.now
    h.controller.mode = "follow"
    second = h.goal(0.0, 2.0)
    assert first.status is GoalStatus.CANCELED
    res = h.run_until_done(second)
    # the new goal halts the tree at once: the 5 s Wait is cancelled in the same instant
    assert ("cancel", pytest.approx(t_wait)) in h.behaviors.events
    assert res.status is GoalStatus.SUCCEEDED
    assert res.result == NavigateResult(0, pytest.approx(h.rt.now - t_wait))
    assert h.base.pose.distance_to(Pose2D(0.0, 2.0)) < 1e-9


def test_a_preempting_goal_gets_the_recoveries_of_a_fresh_tree() -> None:
    """The tree keeps running for the new goal, but not with the old goal's spent retries
    and round-robin place: its first recovery is the first action again, and it has all
    six (office seed 4: a goal moved onto a stuck robot met a 5 s Wait, not BackUp)."""
    h = make_harness(FAST, mode="fail")
    first = h.goal(5.0, 0.0)
    h.rt.scheduler.run_until(60.0, until=lambda: "wait" in h.behaviors.names())
    assert h.nav.tree is not None
    h.rt.scheduler.run_until(60.0, until=lambda: not recovery_running(h.nav.tree))
    assert first.status is GoalStatus.EXECUTING
    tree = h.nav.tree
    h.behaviors.events.clear()
    second = h.goal(0.0, 2.0)
    assert first.status is GoalStatus.CANCELED and h.nav.tree is tree  # kept, not rebuilt
    res = h.run_until_done(second)
    assert res.status is GoalStatus.FAILED
    assert h.behaviors.names("clear_global", "spin", "wait", "backup") == [
        "clear_global", "spin", "wait", "backup", "clear_global", "spin"]
    assert res.error_msg.startswith("could not reach the goal after 6 recoveries")
    assert isinstance(res.result, NavigateResult) and res.result.number_of_recoveries == 6


def test_retries_parameter_and_failing_recovery_are_reported() -> None:
    h = make_harness(NavigateTreeParams(number_of_retries=2, wait_duration=0.2), mode="fail")
    h.behaviors.fail = {"spin": (int(m.BehaviorErrorCode.COLLISION_AHEAD), "collision ahead"),
                        "wait": (int(m.BehaviorErrorCode.TIMEOUT), "timed out"),
                        "backup": (int(m.BehaviorErrorCode.COLLISION_AHEAD), "blocked")}
    res = h.run_until_done(h.goal(5.0, 0.0))
    # recovery 1 = clearing (succeeds); recovery 2: spin, wait and backup fail, then the
    # round robin wraps to clearing, which succeeds; then retries are exhausted
    assert h.behaviors.names("clear_global", "spin", "wait", "backup") == [
        "clear_global", "spin", "wait", "backup", "clear_global"]
    assert res.error_msg.startswith("could not reach the goal after 2 recoveries: FollowPath "
                                    "failed: no valid trajectory")
    assert "then the recovery failed" not in res.error_msg
    # without a local-costmap clearing service every recovery fails: the branch fails
    h.rt.bus.remove_service(m.CLEAR_LOCAL_COSTMAP)
    h.behaviors.events.clear()
    res = h.run_until_done(h.goal(5.0, 0.0))
    assert h.behaviors.names() == ["spin", "wait", "backup"]
    assert res.error_msg == (
        "could not reach the goal after 1 recovery: FollowPath failed: no valid trajectory: "
        "all 520 sampled trajectories collide (NO_VALID_CONTROL); then the recovery failed: "
        "BackUp failed: blocked (COLLISION_AHEAD)")


def test_planner_no_valid_path_fails_with_the_planner_reason() -> None:
    h = make_harness(FAST)
    h.planner.fail = (int(m.PlannerErrorCode.NO_VALID_PATH),
                      "no path from (0.00, 0.00) to (5.00, 0.00): the goal is enclosed")
    res = h.run_until_done(h.goal(5.0, 0.0))
    assert res.status is GoalStatus.FAILED
    assert res.error_code == m.NavigatorErrorCode.NO_VALID_PATH
    assert res.error_msg == ("no path to the goal: planner says no path from (0.00, 0.00) to "
                             "(5.00, 0.00): the goal is enclosed (NO_VALID_PATH); gave up "
                             "after 6 recoveries")
    # every attempt plans, clears the global costmap and plans again
    assert len(h.planner.calls) == 14 and len(h.controller.goals) == 0


def test_cancel_halts_the_tree_and_cancels_the_running_follow_path() -> None:
    h = make_harness(FAST)
    goal = h.goal(30.0, 0.0)
    h.rt.scheduler.run_until(1.0)
    follow = h.controller.goals[-1][1]
    goal.cancel()
    assert goal.status is GoalStatus.CANCELED
    assert follow.status is GoalStatus.CANCELED and follow.cancel_requested
    assert h.controller.cancels == [(1.0, follow)]
    x = h.base.pose.x
    h.rt.scheduler.run_until(3.0)
    assert h.base.pose.x == x and h.nav.tree is None


def test_other_navigator_preempts_with_a_fresh_tree() -> None:
    h = make_harness(FAST)
    first = h.goal(10.0, 0.0)
    h.rt.scheduler.run_until(1.0)
    old_tree = h.nav.tree
    follow = h.controller.goals[-1][1]
    client: ActionClient[m.NavigateThroughPosesGoal] = ActionClient(h.rt.bus,
                                                                    m.NAVIGATE_THROUGH_POSES)
    second = client.send_goal(m.NavigateThroughPosesGoal((
        PoseStamped.from_pose2d(Pose2D(1.0, 1.0)),)))
    assert first.status is GoalStatus.CANCELED and first.result is not None
    assert first.result.error_msg == "preempted by a new goal"
    assert follow.cancel_requested and h.nav.tree is not old_tree
    assert h.run_until_done(second).status is GoalStatus.SUCCEEDED


def test_progress_trigger_fails_follow_path_after_the_dwell_time() -> None:
    tree = NavigateTreeParams(number_of_retries=0, progress_dwell_time=2.0)
    h = make_harness(tree, mode="stall")
    res = h.run_until_done(h.goal(5.0, 0.0))
    # FollowPath starts at 0.10 s; no progress -> cancelled at 2.10 s, the local costmap
    # is cleared, FollowPath retried and cancelled again at 4.10 s; retries 0 -> FAILED
    assert [round(t, 9) for t, _ in h.controller.cancels] == [2.1, 4.1]
    assert res.error_code == m.NavigatorErrorCode.NO_PROGRESS
    assert res.error_msg == (
        "could not reach the goal after 0 recoveries: FollowPath failed: made no progress "
        "toward the goal: the distance remaining along the path went from 5.00 m to 5.00 m "
        "in 2.0 s (progress_epsilon 0.05 m, progress_dwell_time 2 s) "
        "(FAILED_TO_MAKE_PROGRESS)")


@pytest.mark.parametrize(("speed", "fires"), [(0.02, True), (0.03, False)])
def test_progress_trigger_threshold(speed: float, fires: bool) -> None:
    # 0.02 m/s covers 0.04 m < progress_epsilon 0.05 m in the 2 s dwell; 0.03 m/s 0.06 m
    tree = NavigateTreeParams(number_of_retries=0, progress_dwell_time=2.0)
    h = make_harness(tree, speed=speed)
    goal = h.goal(5.0, 0.0)
    h.rt.scheduler.run_until(6.0)
    assert (goal.status is GoalStatus.FAILED) is fires
    assert bool(h.controller.cancels) is fires


def test_goal_in_unknown_frame_fails_with_tf_error_naming_the_frame() -> None:
    h = make_harness(FAST)
    res = h.run_until_done(h.goal(1.0, 0.0, frame="mapp"))
    assert res.status is GoalStatus.FAILED
    assert res.error_code == m.NavigatorErrorCode.TF_ERROR
    assert res.error_msg == ("goal frame 'mapp' is not known to TF (did you mean 'map'?); "
                             "known frames: base_link, map, odom")
    nan = h.goal(math.nan, 0.0)
    assert nan.status is GoalStatus.REJECTED and nan.result is not None
    assert nan.result.error_msg.startswith("goal pose contains NaN or inf (position (nan, 0.0")


def test_invalid_goal_does_not_disturb_the_running_goal() -> None:
    h = make_harness(FAST)
    running = h.goal(3.0, 0.0)
    h.rt.scheduler.run_until(1.0)
    bad = h.goal(1.0, 0.0, frame="gps")
    assert bad.status is GoalStatus.FAILED and running.status is GoalStatus.EXECUTING
    assert h.run_until_done(running).status is GoalStatus.SUCCEEDED


def test_goal_in_odom_frame_is_transformed_to_map() -> None:
    h = make_harness(FAST, map_to_odom=Pose2D(1.0, 2.0, math.pi / 2))
    res = h.run_until_done(h.goal(1.0, 0.0, frame="odom"))
    assert res.status is GoalStatus.SUCCEEDED
    planned = h.planner.calls[0][1].goal
    assert planned.header.frame_id == "map"
    p = planned.to_pose2d()
    assert (p.x, p.y, p.theta) == pytest.approx((1.0, 3.0, math.pi / 2), abs=1e-12)


def test_navigate_through_poses_plans_leg_by_leg_and_drops_passed_poses() -> None:
    h = make_harness(FAST)
    client: ActionClient[m.NavigateThroughPosesGoal] = ActionClient(h.rt.bus,
                                                                    m.NAVIGATE_THROUGH_POSES)
    poses = tuple(PoseStamped.from_pose2d(Pose2D(x, y)) for x, y in ((2, 0), (2, 2), (4, 2)))
    goal = client.send_goal(m.NavigateThroughPosesGoal(poses), feedback_cb=h.feedback.append)
    res = h.run_until_done(goal)
    assert res.status is GoalStatus.SUCCEEDED
    legs = [(c.start.to_pose2d() if c.start else None, c.goal.to_pose2d())
            for _, c in h.planner.calls[:3]]
    assert legs == [(None, Pose2D(2, 0)), (Pose2D(2, 0), Pose2D(2, 2)),
                    (Pose2D(2, 2), Pose2D(4, 2))]
    first = next(f for f in h.feedback if f.distance_remaining > 0)
    assert first.distance_remaining == pytest.approx(6.0, abs=1e-9)
    remaining = [f.number_of_poses_remaining for f in h.feedback]
    assert remaining[0] == 3 and remaining[-1] == 1 and 2 in remaining
    assert remaining == sorted(remaining, reverse=True)
    # passing a pose changes {goals} -> replanned from the robot through what is left
    assert len(h.planner.calls) > 3
    assert h.base.pose.distance_to(Pose2D(4.0, 2.0)) < 1e-9


def test_two_navigators_have_separate_blackboards() -> None:
    from navstack.navigation.bt_navigator import BtNavigator

    h = make_harness(FAST)
    other = BtNavigator(h.rt, BtNavigatorParams(navigators=()), name="bt_navigator_2")
    assert other.namespace != h.nav.namespace
    h.run_until_done(h.goal(1.0, 0.0))
    with pytest.raises(KeyError):
        other._board.get("goal")


def test_missing_server_unknown_tree_and_deactivation_are_explained() -> None:
    h = make_harness(NavigateTreeParams(number_of_retries=0))
    follow_server = h.rt.bus.action_servers.pop(m.FOLLOW_PATH)
    res = h.run_until_done(h.goal(2.0, 0.0))
    assert res.error_msg == (
        "could not reach the goal after 0 recoveries: FollowPath failed: action server "
        "'/follow_path' is not available after 0.02 s (known: /backup, /compute_path_to_pose, "
        "/drive_on_heading, /navigate_through_poses, /navigate_to_pose, /spin, /wait); start "
        "and activate the node that provides it (UNKNOWN)")
    client: ActionClient[m.NavigateToPoseGoal] = ActionClient(h.rt.bus, m.NAVIGATE_TO_POSE)
    bad_tree = client.send_goal(m.NavigateToPoseGoal(PoseStamped.from_pose2d(Pose2D(1.0, 0.0)),
                                                     "navigate_to_pose_w_replaning"))
    assert bad_tree.status is GoalStatus.REJECTED and bad_tree.result is not None
    assert bad_tree.result.error_msg.startswith(
        "unknown behavior_tree 'navigate_to_pose_w_replaning' (did you mean "
        "'navigate_to_pose_w_replanning_and_recovery'?); known: ")
    h.rt.bus.action_servers[m.FOLLOW_PATH] = follow_server
    running = h.goal(5.0, 0.0)
    h.rt.scheduler.run_until(h.rt.now + 0.5)
    assert running.status is GoalStatus.EXECUTING
    h.nav.deactivate()
    assert running.status is GoalStatus.CANCELED and running.result is not None
    assert running.result.error_msg == "bt_navigator was deactivated"


def test_continue_from_goal_radius_plans_the_next_goal_from_the_goal_just_reached() -> None:
    """A waypoint route plans waypoint to waypoint: the first plan of a goal accepted
    while the robot stands within the radius of the goal it reached starts at that goal
    (ComputePathToPose's start); a replan, a robot further away, and the default (0)
    plan from the robot."""
    h = make_harness(FAST.model_copy(update={"continue_from_goal_radius": 0.5}))
    assert h.run_until_done(h.goal(5.0, 0.0)).status is GoalStatus.SUCCEEDED
    h.base.teleport(Pose2D(5.3, 0.2, 0.1))  # stopped inside the goal tolerance
    t0 = h.rt.now
    h.behaviors.path_valid = lambda t: not t0 + 2.5 <= t < t0 + 3.5
    assert h.run_until_done(h.goal(5.0, 4.0, math.pi / 2)).status is GoalStatus.SUCCEEDED
    first, replan = (c for _, c in h.planner.calls[1:])
    assert first.start is not None and first.start.to_pose2d() == Pose2D(5.0, 0.0)
    assert replan.start is None  # the path went invalid: replanned from the robot
    h.base.teleport(Pose2D(5.0, 4.6, math.pi / 2))  # 0.6 m off: beyond the radius
    n = len(h.planner.calls)
    assert h.run_until_done(h.goal(0.0, 4.0)).status is GoalStatus.SUCCEEDED
    assert h.planner.calls[n][1].start is None
    off = make_harness(FAST)  # Nav2's behaviour by default
    off.run_until_done(off.goal(5.0, 0.0))
    off.base.teleport(Pose2D(5.3, 0.2, 0.1))
    off.run_until_done(off.goal(5.0, 4.0))
    assert [c.start for _, c in off.planner.calls] == [None, None]

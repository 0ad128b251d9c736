"""WaypointFollower against a scripted NavigateToPose server (and the real BtNavigator),
and the waypoints YAML loader's error messages."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from navstack.core.errors import ConfigError, ConfigErrors
from navstack.core.msgs import Pose2D, PoseStamped
from navstack.navigation import messages as m
from navstack.navigation.trees import NavigateTreeParams
from navstack.navigation.waypoint_follower import (
    FollowWaypointsErrorCode,
    WaypointFollower,
    WaypointFollowerParams,
    load_waypoints,
)
from navstack.runtime.actions import ActionClient, ActionServer, GoalHandle, GoalStatus
from navstack.runtime.node import Runtime
from tests.navigation.fakes import make_harness

NO_PATH = (int(m.NavigatorErrorCode.NO_VALID_PATH), "no path to the goal: planner says boxed in")


class FakeNavigator:
    """NavigateToPose: succeeds 0.5 s after each goal unless its x is in ``fail``."""

    def __init__(self, rt: Runtime) -> None:
        self.rt = rt
        self.goals: list[tuple[float, GoalHandle[m.NavigateToPoseGoal]]] = []
        self.fail: dict[float, tuple[int, str]] = {}
        ActionServer(rt.bus, m.NAVIGATE_TO_POSE, self._on_goal, lambda h: h.canceled())

    def _on_goal(self, h: GoalHandle[m.NavigateToPoseGoal]) -> bool:
        self.goals.append((self.rt.now, h))
        h.execute()
        self.rt.scheduler.call_later(0.5, self._end, h)
        return True

    def _end(self, h: GoalHandle[m.NavigateToPoseGoal]) -> None:
        if h.done:
            return
        x = h.goal.pose.pose.position.x
        if x in self.fail:
            h.fail(*self.fail[x])
        else:
            h.succeed()

    def xs(self) -> list[float]:
        return [h.goal.pose.pose.position.x for _, h in self.goals]


def setup(stop_on_failure: bool = True) -> tuple[Runtime, FakeNavigator, WaypointFollower]:
    rt = Runtime()
    nav = FakeNavigator(rt)
    follower = WaypointFollower(rt, WaypointFollowerParams(stop_on_failure=stop_on_failure))
    rt.bring_up()
    return rt, nav, follower


def follow(rt: Runtime, xs: list[float], names: tuple[str, ...] = (),
           feedback: list[Any] | None = None) -> GoalHandle[m.FollowWaypointsGoal]:
    poses = tuple(PoseStamped.from_pose2d(Pose2D(x, 0.0)) for x in xs)
    client: ActionClient[m.FollowWaypointsGoal] = ActionClient(rt.bus, m.FOLLOW_WAYPOINTS)
    return client.send_goal(m.FollowWaypointsGoal(poses, names),
                            feedback_cb=feedback.append if feedback is not None else None)


def test_waypoints_are_sent_one_by_one_in_order() -> None:
    rt, nav, _ = setup()
    feedback: list[m.FollowWaypointsFeedback] = []
    h = follow(rt, [3.0, 1.0, 2.0], ("dock", "a", "b"), feedback)
    rt.scheduler.run_until(10.0, until=lambda: h.done)
    assert h.status is GoalStatus.SUCCEEDED and h.result is not None
    assert h.result.result == m.FollowWaypointsResult(())
    assert nav.xs() == [3.0, 1.0, 2.0]
    assert [t for t, _ in nav.goals] == pytest.approx([0.0, 0.5, 1.0])
    assert feedback == [m.FollowWaypointsFeedback(0, "dock"), m.FollowWaypointsFeedback(1, "a"),
                        m.FollowWaypointsFeedback(2, "b")]


def test_stop_on_failure_true_stops_at_the_missed_waypoint() -> None:
    rt, nav, _ = setup(stop_on_failure=True)
    nav.fail[1.0] = NO_PATH
    h = follow(rt, [3.0, 1.0, 2.0], ("dock", "a", "b"))
    rt.scheduler.run_until(10.0, until=lambda: h.done)
    assert h.status is GoalStatus.FAILED and h.result is not None
    assert h.result.error_code == FollowWaypointsErrorCode.STOP_ON_MISSED_WAYPOINT
    assert h.result.error_msg == ("waypoint 1 'a' failed: no path to the goal: planner says "
                                  "boxed in; stopping (stop_on_failure is true)")
    assert h.result.result.missed_waypoints == (m.MissedWaypoint(1, "a", *NO_PATH),)
    assert nav.xs() == [3.0, 1.0]


def test_stop_on_failure_false_records_and_continues() -> None:
    rt, nav, _ = setup(stop_on_failure=False)
    nav.fail[1.0] = NO_PATH
    nav.fail[4.0] = (int(m.NavigatorErrorCode.TF_ERROR), "goal frame 'x' is not known to TF")
    h = follow(rt, [3.0, 1.0, 2.0, 4.0])
    rt.scheduler.run_until(10.0, until=lambda: h.done)
    assert h.status is GoalStatus.SUCCEEDED and h.result is not None
    assert h.result.result.missed_waypoints == (
        m.MissedWaypoint(1, "waypoint 1", *NO_PATH),
        m.MissedWaypoint(3, "waypoint 3", int(m.NavigatorErrorCode.TF_ERROR),
                         "goal frame 'x' is not known to TF"))
    assert nav.xs() == [3.0, 1.0, 2.0, 4.0]


def test_cancel_preempt_and_foreign_preemption() -> None:
    rt, nav, _ = setup()
    h = follow(rt, [1.0, 2.0])
    rt.scheduler.run_until(0.2)
    h.cancel()
    assert h.status is GoalStatus.CANCELED and nav.goals[0][1].status is GoalStatus.CANCELED

    first = follow(rt, [1.0, 2.0])
    second = follow(rt, [5.0])
    assert first.status is GoalStatus.CANCELED and first.result is not None
    assert first.result.error_msg == "preempted by a new goal"
    rt.scheduler.run_until(5.0, until=lambda: second.done)
    assert second.status is GoalStatus.SUCCEEDED and nav.xs()[-1] == 5.0

    third = follow(rt, [7.0, 8.0])
    rt.scheduler.run_for(0.1)
    nav.goals[-1][1].canceled(reason="preempted by a new goal")  # someone else took over
    rt.scheduler.run_for(0.1)
    assert third.status is GoalStatus.CANCELED and third.result is not None
    assert third.result.error_msg == ("navigation to waypoint 0 'waypoint 0' was canceled by "
                                      "another client: preempted by a new goal")

    empty = follow(rt, [])
    assert empty.status is GoalStatus.FAILED and empty.result is not None
    assert empty.result.error_code == FollowWaypointsErrorCode.NO_VALID_WAYPOINTS
    mismatch = follow(rt, [1.0, 2.0], ("only-one",))
    assert mismatch.status is GoalStatus.REJECTED


def test_follows_waypoints_through_the_real_navigator() -> None:
    h = make_harness(NavigateTreeParams(wait_duration=0.2))
    WaypointFollower(h.rt)
    h.rt.bring_up()
    goal = follow(h.rt, [2.0, -1.0, 0.5])
    h.rt.scheduler.run_until(60.0, until=lambda: goal.done)
    assert goal.status is GoalStatus.SUCCEEDED
    assert [c.goal.to_pose2d().x for _, c in h.planner.calls] == [2.0, -1.0, 0.5]
    assert h.base.pose.distance_to(Pose2D(0.5, 0.0)) < 1e-9


# --- YAML --------------------------------------------------------------------------------
GOOD = """\
waypoints:
  - name: dock
    position: {x: 1.0, y: 2.0}
  - name: shelf
    position: {x: -3, y: 0.5, z: 0.0}
    orientation: {z: 0.7071068, w: 0.7071068}
    frame_id: odom
  - name: door
    position: {x: 4.0, y: 4.0}
order: [shelf, dock, shelf, door]
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "route.yaml"
    path.write_text(text)
    return path


def test_load_waypoints_reorders_and_fills_defaults(tmp_path: Path) -> None:
    wps = load_waypoints(write(tmp_path, GOOD))
    assert [n for n, _ in wps] == ["shelf", "dock", "shelf", "door"]
    shelf = wps[0][1]
    assert shelf.header.frame_id == "odom" and wps[1][1].header.frame_id == "map"
    assert shelf.to_pose2d().x == -3.0 and shelf.to_pose2d().theta == pytest.approx(math.pi / 2)
    assert wps[1][1].pose.orientation.w == 1.0


@pytest.mark.parametrize(("text", "message"), [
    ("waypoints:\n  - name: a\n    position: {x: 1, y: 2}\n  - name: b\n    orientation: {w: 1}\n",
     "waypoints[1].position: required key is missing"),
    ("waypoints:\n  - name: a\n    position: {x: abc, y: 2}\n",
     "waypoints[0].position.x: must be a number (got 'abc')"),
    ("waypoints:\n  - name: a\n    position: {x: .nan, y: 2}\n",
     "waypoints[0].position.x: must be a finite number (got nan)"),
    ("waypoints:\n  - name: a\n    position: {x: 1, y: 2}\n    orientation: {z: 0.5, w: 0}\n",
     "waypoints[0].orientation: quaternion is not normalised (|q| = 0.5000); use unit length, "
     "e.g. {z: 0.7071, w: 0.7071} for a yaw of 90 degrees"),
    ("waypoints:\n  - name: dock\n    position: {x: 1, y: 2}\n  - name: a\n    position: "
     "{x: 1, y: 2}\norder: [a, dock, dok]\n",
     "order[2]: unknown waypoint 'dok'; known: dock, a (did you mean 'dock'?)"),
    ("waypoints:\n  - name: a\n    position: {x: 1, y: 2}\n  - name: a\n    position: "
     "{x: 3, y: 2}\n", "waypoints[1].name: duplicate name 'a' (also waypoints[0])"),
    ("waypoints:\n  - position: {x: 1, y: 2}\n", "waypoints[0].name: required key is missing"),
    ("waypoints:\n  - name: a\n    position: {x: 1}\n",
     "waypoints[0].position.y: required key is missing"),
    ("waypoint:\n  - name: a\n", "waypoints: required key is missing (the file needs a "
     "top-level 'waypoints' list)"),
    ("waypoints: [\n", "invalid YAML at line 2, column 1: expected the node content, but "
     "found '<stream end>'"),
])
def test_load_waypoints_errors_name_file_and_key(tmp_path: Path, text: str, message: str
                                                 ) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_waypoints(path)
    assert str(info.value).startswith(f"{path}: {message}")


def test_load_waypoints_reports_every_problem_and_missing_file(tmp_path: Path) -> None:
    path = write(tmp_path, "waypoints:\n  - name: a\n    positon: {x: 1, y: 2}\n")
    with pytest.raises(ConfigErrors) as info:
        load_waypoints(path)
    assert str(info.value).splitlines() == [
        f"{path}: waypoints[0].positon: unknown key (did you mean 'position'?)",
        f"{path}: waypoints[0].position: required key is missing"]
    with pytest.raises(ConfigError, match="cannot read the waypoints file: No such file"):
        load_waypoints(tmp_path / "missing.yaml")

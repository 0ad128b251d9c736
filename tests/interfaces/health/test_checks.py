"""Each health check on hand-made observations: verdicts and exact messages."""

from __future__ import annotations

import numpy as np

from navstack.core.msgs import Pose2D
from navstack.core.tf import TransformTree, tf_from_pose2d, tf_to_stamped
from navstack.interfaces.health.checks import (
    cmd_vel_published,
    controller_active,
    costmaps_not_lethal,
    lifecycle,
    localization_covariance,
    plan_frame,
    tf_chain,
    topic_rate,
    velocity_limits,
)
from navstack.interfaces.health.model import (
    CostmapSnapshot,
    GoalSpan,
    HealthParams,
    Observations,
)

P = HealthParams()


def _every(n: int, dt: float) -> np.ndarray[tuple[int], np.dtype[np.float64]]:
    """``n`` message times ``dt, 2 dt, ..., n dt``."""
    return (np.arange(1, n + 1) * dt).astype(np.float64)


def _tree(odom_stamps: list[float], map_stamps: list[float]) -> TransformTree:
    tree = TransformTree(cache_time=100.0)
    tree.add_static("base_link", "laser", Pose2D(0.1, 0.0, 0.0))
    for t in odom_stamps:
        tree.set_transform(tf_to_stamped(tf_from_pose2d(Pose2D(t, 0.0, 0.0)), "odom",
                                         "base_link", t), False)
    for t in map_stamps:
        tree.set_transform(tf_to_stamped(tf_from_pose2d(Pose2D()), "map", "odom", t), False)
    return tree


def test_topic_rate_passes_at_the_expected_rate_and_names_a_silent_topic() -> None:
    obs = Observations("test", 0.0, 4.0, topic_times={"/scan": _every(40, 0.1)},
                       expected_rates={"/scan": 10.0, "/odom": 50.0})
    ok = topic_rate(obs, P, "/scan")
    assert ok.ok and ok.detail == "10.0 Hz over the last 2.0 s (expected 10.0 Hz)"
    bad = topic_rate(obs, P, "/odom")
    assert not bad.ok
    assert bad.detail == "0.0 Hz over the last 2.0 s (expected 50.0 Hz); nothing published"
    assert bad.fix == "check that the base's odometry (simulator) is running and publishes /odom"
    # 8 Hz is the 20 % tolerance below 10 Hz: still fine; 7.5 Hz is not
    slow = Observations("test", 0.0, 4.0, topic_times={"/scan": _every(32, 0.125)},
                        expected_rates={"/scan": 10.0})
    assert topic_rate(slow, P, "/scan").ok
    slower = Observations("test", 0.0, 4.0, topic_times={"/scan": _every(30, 4 / 30)},
                          expected_rates={"/scan": 10.0})
    assert not topic_rate(slower, P, "/scan").ok


def test_cmd_vel_is_judged_only_while_a_goal_is_active() -> None:
    times = _every(40, 0.05)  # 20 Hz during 0..2 s, then silence
    obs = Observations("test", 0.0, 6.0, topic_times={"/cmd_vel": times},
                       expected_rates={"/cmd_vel": 20.0}, goals=[GoalSpan(0.0, 2.0)])
    late = cmd_vel_published(obs, P)  # last 2 s: no goal active
    assert late.ok and late.detail.startswith("not judged")
    whole = cmd_vel_published(obs, P, since=0.0)
    assert whole.ok
    assert whole.detail == "40 /cmd_vel messages in 2.0 s of active goal (20.0 Hz, expected " \
                           "20.0 Hz)"
    running = Observations("test", 0.0, 6.0, topic_times={"/cmd_vel": times},
                           expected_rates={"/cmd_vel": 20.0}, goals=[GoalSpan(0.0)])
    silent = cmd_vel_published(running, P)
    assert not silent.ok
    assert silent.detail == "0 /cmd_vel messages in 2.0 s of active goal (0.0 Hz, expected " \
                            "20.0 Hz)"


def test_tf_names_the_stale_edge_with_its_age() -> None:
    odom = list(np.arange(0, 41) * 0.125)  # fresh up to t=5
    fresh = Observations("test", 0.0, 5.0, tf=_tree(odom, odom), sensor_frames=("laser",))
    ok = tf_chain(fresh, P)
    assert ok.ok
    assert ok.detail == ("map -> odom -> base_link -> laser resolves; map->odom, "
                         "odom->base_link fresh (< 0.30 s)")
    stale = Observations("test", 0.0, 5.0, tf=_tree(odom, [0.0, 1.0]), sensor_frames=("laser",))
    bad = tf_chain(stale, P)
    assert not bad.ok
    assert bad.detail == "map->odom 4.00 s old at t=5.00 s (newest stamp 1.00 s)"
    missing = Observations("test", 0.0, 5.0, tf=_tree(odom, []), sensor_frames=("laser",))
    gone = tf_chain(missing, P)
    assert gone.detail.startswith("map->odom never received; frame 'map' does not exist")


def test_lifecycle_and_controller_name_inactive_nodes() -> None:
    obs = Observations("test", 0.0, 1.0, node_states={
        "simulator": "ACTIVE", "controller_server": "INACTIVE", "planner_server": "ACTIVE"})
    res = lifecycle(obs, P)
    assert (res.ok, res.detail) == (False, "controller_server INACTIVE")
    assert res.fix.startswith("activate controller_server (lifecycle configure -> activate")
    ctrl = controller_active(obs, P)
    assert (ctrl.ok, ctrl.detail) == (False, "controller_server is INACTIVE")
    bag = Observations("bag", 0.0, 10.0, goals=[GoalSpan(0.0)], plans=[(0.5, "map")],
                       topic_times={"/cmd_vel": np.array([0.6])})
    inferred = controller_active(bag, P)
    assert not inferred.ok
    assert inferred.detail == ("inferred from the recording: a plan was published at t=0.50 s "
                               "but only 1 /cmd_vel message(s) followed in 9.5 s")


def test_plan_frame_must_match_the_global_costmap() -> None:
    obs = Observations("test", 0.0, 1.0, plans=[(0.5, "odom")], global_frame="map")
    res = plan_frame(obs, P)
    assert not res.ok
    assert res.detail == "/plan at t=0.50 s is in 'odom', the global costmap is in 'map'"
    obs.plans.append((0.8, "map"))
    assert plan_frame(obs, P).ok


def test_velocity_limits_zero_live_and_from_a_recording() -> None:
    live = Observations("test", 0.0, 1.0, velocity_limits={
        "FollowPath.max_vel_x": 0.0, "FollowPath.max_vel_theta": 1.0, "robot.max_vel_x": 0.5})
    res = velocity_limits(live, P)
    assert (res.ok, res.detail) == (False, "FollowPath.max_vel_x = 0")
    t = np.arange(40) * 0.05
    backing = np.column_stack((t, np.full(40, -0.1), np.zeros(40)))
    bag = Observations("bag", 0.0, 2.0, cmd=backing, goals=[GoalSpan(0.0)],
                       plans=[(0.0, "map")])
    inferred = velocity_limits(bag, P)
    assert not inferred.ok
    assert inferred.detail == ("inferred from the recording: none of 40 commands during a "
                               "planned goal drove forward (largest vx -0.10 m/s)")


def test_costmap_all_lethal_or_robot_in_lethal() -> None:
    obs = Observations("test", 0.0, 1.0, costmaps=[
        CostmapSnapshot("global_costmap", "map", 1000, 0.95, 254, True),
        CostmapSnapshot("local_costmap", "odom", 3600, 0.25, 254, True),
        CostmapSnapshot("other", "odom", 3600, 0.25, 0, False)])
    g, loc, other = costmaps_not_lethal(obs, P)
    assert not g.ok
    assert g.detail == "95.0% of 1000 known cells lethal/inscribed; cost under the robot 254"
    assert not loc.ok and loc.detail.endswith("(footprint in collision)")
    assert other.ok


def test_localization_covariance_bounded() -> None:
    obs = Observations("test", 0.0, 1.0, covariance=np.array([[0.5, 0.1, 0.1, 0.05]]),
                       covariance_topic="/amcl_pose")
    assert localization_covariance(obs, P).ok
    obs.covariance = np.array([[0.75, 1.5, 0.1, 0.05]])
    res = localization_covariance(obs, P)
    assert not res.ok
    assert res.detail == ("/amcl_pose at t=0.75 s: std x 1.500 m, y 0.100 m, yaw 0.050 rad")

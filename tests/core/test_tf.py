"""TransformTree: interpolation, chains, latest common time, buffers, errors, checks."""

from __future__ import annotations

import math
import random

import pytest

from navstack.core.errors import (
    ConfigError,
    ConnectivityError,
    ExtrapolationError,
    InvalidMessage,
    TransformError,
    UnknownFrameError,
)
from navstack.core.geometry import angle_diff, normalize_angle, rpy_to_quaternion
from navstack.core.msgs import (
    Header,
    Pose2D,
    Quaternion,
    TFMessage,
    Transform,
    TransformStamped,
    Vector3,
)
from navstack.core.tf import (
    FrameConflictError,
    TransformTree,
    transform_pose2d,
)
from navstack.core.tf_checks import check_chain, find_jumps


def ts(parent: str, child: str, t: float, x: float = 0.0, y: float = 0.0, yaw: float = 0.0,
       z: float = 0.0) -> TransformStamped:
    return TransformStamped(Header(t, parent), child,
                            Transform(Vector3(x, y, z), Quaternion.from_yaw(yaw)))


def ts_rpy(parent: str, child: str, t: float, roll: float, pitch: float,
           yaw: float) -> TransformStamped:
    return TransformStamped(Header(t, parent), child,
                            Transform(Vector3(), Quaternion(*rpy_to_quaternion(roll, pitch, yaw))))


def assert_pose(p: Pose2D, x: float, y: float, theta: float, tol: float = 1e-12) -> None:
    assert p.x == pytest.approx(x, abs=tol)
    assert p.y == pytest.approx(y, abs=tol)
    assert abs(angle_diff(p.theta, theta)) <= tol


def moving(t: float) -> tuple[float, float, float]:
    """Constant velocity in odom: 0.5 m/s in x, -0.2 m/s in y, 0.3 rad/s, crossing +-pi."""
    return 1.0 + 0.5 * t, 2.0 - 0.2 * t, normalize_angle(3.0 + 0.3 * t)


def odom_tree(t_end: float = 5.0, rate: float = 10.0) -> TransformTree:
    tree = TransformTree()
    for k in range(round(t_end * rate) + 1):
        t = k / rate
        tree.set_transform(ts("odom", "base_link", t, *moving(t)), authority="odom_node")
    return tree


# --- interpolation ---------------------------------------------------------------------------
@pytest.mark.parametrize("t", [0.0, 0.05, 0.4321, 1.234, 2.71828, 4.95, 5.0])
def test_interpolation_is_exact_on_constant_velocity_motion(t: float) -> None:
    assert_pose(odom_tree().lookup_pose2d("odom", "base_link", t), *moving(t))


def test_lookup_at_a_sample_returns_the_sample_exactly() -> None:
    tree = odom_tree()
    out = tree.lookup("odom", "base_link", 2.0)
    q = Quaternion.from_yaw(moving(2.0)[2])
    assert out.header == Header(2.0, "odom")
    assert out.child_frame_id == "base_link"
    assert out.transform.translation == Vector3(2.0, 1.6, 0.0)
    assert out.transform.rotation == pytest.approx(q)


def test_slerp_is_exact_for_a_constant_rate_roll() -> None:
    tree = TransformTree()
    tree.set_transform(ts_rpy("base_link", "imu", 0.0, 0.2, 0.0, 0.0))
    tree.set_transform(ts_rpy("base_link", "imu", 1.0, 1.0, 0.0, 0.0))
    q = tree.lookup("base_link", "imu", 0.25).transform.rotation
    assert (q.x, q.y, q.z, q.w) == pytest.approx(rpy_to_quaternion(0.4, 0.0, 0.0), abs=1e-15)


# --- chains ----------------------------------------------------------------------------------
def rep105_tree() -> TransformTree:
    """map->odom (AMCL, constant), odom->base_link (moving +x at 1 m/s), static sensors."""
    tree = TransformTree()
    for k in range(6):
        tree.set_transform(ts("map", "odom", float(k), 1.0, 2.0, math.pi / 2), authority="amcl")
        tree.set_transform(ts("odom", "base_link", float(k), float(k)), authority="odom")
    tree.add_static("base_link", "laser", Pose2D(0.2, 0.0, math.pi), z=0.3)
    tree.add_static("base_link", "imu", Pose2D(0.0, 0.1, 0.0))
    return tree


def test_chain_across_static_and_dynamic_edges() -> None:
    tree = rep105_tree()
    # laser in odom at t=2: (2.2, 0, pi); map->odom rotates by pi/2 and shifts by (1, 2)
    assert_pose(tree.lookup_pose2d("map", "laser", 2.0), 1.0, 4.2, -math.pi / 2)
    full = tree.lookup("map", "laser", 2.0)
    assert full.transform.translation.z == pytest.approx(0.3)
    assert (full.header.frame_id, full.child_frame_id) == ("map", "laser")
    # inverse direction and a point through it
    assert_pose(tree.lookup_pose2d("laser", "map", 2.0).compose(Pose2D(1.0, 4.2, -math.pi / 2)),
                0.0, 0.0, 0.0)
    # siblings under base_link: the imu seen from the backwards-facing laser
    assert_pose(tree.lookup_pose2d("laser", "imu", 3.7), 0.2, -0.1, math.pi)
    # interpolated chain at t=2.5
    assert_pose(tree.lookup_pose2d("map", "base_link", 2.5), 1.0, 4.5, math.pi / 2)
    assert_pose(transform_pose2d(tree, Pose2D(1.0, 0.0, 0.0), "laser", "map", 2.0),
                1.0, 3.2, -math.pi / 2)
    assert_pose(tree.lookup_pose2d("odom", "odom"), 0.0, 0.0, 0.0)


def test_structure_queries() -> None:
    tree = rep105_tree()
    assert tree.frames() == ["base_link", "imu", "laser", "map", "odom"]
    assert tree.parent_of("base_link") == "odom"
    assert tree.parent_of("map") is None
    assert tree.latest_time("base_link") == 5.0
    assert tree.latest_time("laser") is None  # static
    assert tree.latest_time("map") is None  # root
    assert "laser" in tree and "lidar" not in tree
    with pytest.raises(UnknownFrameError):
        tree.parent_of("lidar")
    assert tree.describe().splitlines() == [
        "odom->base_link: dynamic, 6 samples in [0.000, 5.000] s, authority 'odom'",
        "base_link->imu: static",
        "base_link->laser: static",
        "map->odom: dynamic, 6 samples in [0.000, 5.000] s, authority 'amcl'",
    ]


# --- latest common time ----------------------------------------------------------------------
def test_none_uses_latest_time_common_to_the_chain() -> None:
    tree = rep105_tree()
    for k in range(6, 9):  # odometry runs ahead of localization
        tree.set_transform(ts("odom", "base_link", float(k), float(k)))
    out = tree.lookup("map", "laser")
    assert out.header.stamp == 5.0
    assert_pose(tree.lookup_pose2d("map", "laser"), *tree.lookup_pose2d("map", "laser", 5.0)
                .as_array())
    assert tree.lookup("odom", "base_link").header.stamp == 8.0
    assert tree.lookup("base_link", "laser").header.stamp == 0.0  # static only
    assert_pose(tree.lookup_pose2d("odom", "base_link"), 8.0, 0.0, 0.0)


def test_none_with_disjoint_windows_raises_past_extrapolation() -> None:
    tree = TransformTree()
    for t in (0.0, 1.0):
        tree.set_transform(ts("map", "odom", t))
    for t in (2.0, 5.0):
        tree.set_transform(ts("odom", "base_link", t))
    with pytest.raises(ExtrapolationError) as err:
        tree.lookup("map", "base_link")
    assert str(err.value) == (
        "lookup of 'base_link' in 'map' at t=1.000 s (latest common time) would extrapolate "
        "into the past: edge odom->base_link holds [2.000, 5.000] s")


# --- buffer ----------------------------------------------------------------------------------
def test_out_of_order_inserts_give_the_same_buffer() -> None:
    stamps = [k / 10.0 for k in range(51)]
    shuffled = stamps[:]
    random.Random(7).shuffle(shuffled)
    tree = TransformTree()
    for t in shuffled:
        tree.set_transform(ts("odom", "base_link", t, *moving(t)))
    assert [s.header.stamp for s in tree.edge_samples("base_link")] == stamps
    for t in (0.0, 0.33, 2.5, 4.99):
        assert_pose(tree.lookup_pose2d("odom", "base_link", t), *moving(t))


def test_same_stamp_overwrites() -> None:
    tree = odom_tree()
    tree.set_transform(ts("odom", "base_link", 2.0, 9.0, 9.0, 0.5))
    assert len(tree.edge_samples("base_link")) == 51
    assert_pose(tree.lookup_pose2d("odom", "base_link", 2.0), 9.0, 9.0, 0.5)


def test_pruning_keeps_cache_time_behind_the_newest_stamp() -> None:
    tree = TransformTree(cache_time=2.0)
    for k in range(11):
        assert tree.set_transform(ts("odom", "base_link", float(k), float(k)))
    assert [s.header.stamp for s in tree.edge_samples("base_link")] == [8.0, 9.0, 10.0]
    assert tree.set_transform(ts("odom", "base_link", 3.0)) is False  # tf2 TF_OLD_DATA
    assert len(tree.edge_samples("base_link")) == 3
    with pytest.raises(ExtrapolationError) as err:
        tree.lookup("odom", "base_link", 7.5)
    assert str(err.value) == (
        "lookup of 'base_link' in 'odom' at t=7.500 s would extrapolate into the past: "
        "edge odom->base_link holds [8.000, 10.000] s")


def test_cache_time_must_be_positive() -> None:
    with pytest.raises(ConfigError) as err:
        TransformTree(cache_time=0.0)
    assert str(err.value) == "cache_time: must be a positive duration in seconds, got 0.0"


# --- errors ----------------------------------------------------------------------------------
def small_tree() -> TransformTree:
    tree = TransformTree()
    tree.set_transform(ts("map", "odom", 1.0))
    for t in (1.0, 3.0, 5.0):
        tree.set_transform(ts("odom", "base_link", t, t))
    return tree


def test_unknown_frame_message() -> None:
    tree = small_tree()
    with pytest.raises(UnknownFrameError) as err:
        tree.lookup("map", "lidar")
    assert str(err.value) == "frame 'lidar' does not exist; known frames: base_link, map, odom"
    with pytest.raises(UnknownFrameError) as err:
        tree.lookup("base_lnk", "map")
    assert str(err.value) == ("frame 'base_lnk' does not exist (did you mean 'base_link'?); "
                              "known frames: base_link, map, odom")
    with pytest.raises(UnknownFrameError) as err:
        TransformTree().lookup("map", "odom")
    assert str(err.value) == "frame 'map' does not exist; known frames: none (the tree is empty)"


def test_connectivity_message() -> None:
    tree = TransformTree()
    tree.set_transform(ts("odom", "base_link", 0.0))
    tree.add_static("base_link", "laser", Pose2D(0.1, 0.0, 0.0))
    tree.add_static("map", "dock", Pose2D(3.0, 1.0, 0.0))
    with pytest.raises(ConnectivityError) as err:
        tree.lookup("map", "laser")
    assert str(err.value) == ("cannot transform 'laser' to 'map': they are not connected "
                              "(roots 'odom' and 'map')")


def test_extrapolation_messages() -> None:
    tree = small_tree()
    with pytest.raises(ExtrapolationError) as err:
        tree.lookup("odom", "base_link", 5.2)
    assert str(err.value) == (
        "lookup of 'base_link' in 'odom' at t=5.200 s would extrapolate into the future: "
        "edge odom->base_link holds [1.000, 5.000] s")
    with pytest.raises(ExtrapolationError) as err:
        tree.lookup_pose2d("map", "base_link", 0.5)  # first failing edge from the source up
    assert str(err.value) == (
        "lookup of 'base_link' in 'map' at t=0.500 s would extrapolate into the past: "
        "edge odom->base_link holds [1.000, 5.000] s")
    with pytest.raises(ExtrapolationError) as err:
        tree.lookup("map", "base_link", 3.0)
    assert str(err.value) == (
        "lookup of 'base_link' in 'map' at t=3.000 s would extrapolate into the future: "
        "edge map->odom holds [1.000, 1.000] s")
    with pytest.raises(ExtrapolationError) as err:  # more digits when 3 would look in-window
        tree.lookup("odom", "base_link", 5.0004)
    assert str(err.value) == (
        "lookup of 'base_link' in 'odom' at t=5.000400 s would extrapolate into the future: "
        "edge odom->base_link holds [1.000000, 5.000000] s")
    # a float-rounding sized overshoot is absorbed, not an error
    assert_pose(tree.lookup_pose2d("odom", "base_link", 5.0 + 1e-7), 5.0, 0.0, 0.0)


def test_every_lookup_error_is_a_transform_error_and_lookup_error() -> None:
    for cls in (UnknownFrameError, ConnectivityError, ExtrapolationError):
        assert issubclass(cls, TransformError) and issubclass(cls, LookupError)


def test_can_transform() -> None:
    tree = small_tree()
    assert tree.can_transform("map", "base_link", 1.0)
    assert tree.can_transform("odom", "base_link")
    assert not tree.can_transform("map", "base_link", 3.0)  # map->odom only holds t=1
    assert not tree.can_transform("map", "lidar")
    tree.add_static("dock_frame", "dock", Pose2D())
    assert not tree.can_transform("map", "dock")


def test_insert_conflicts_and_invalid_messages() -> None:
    tree = small_tree()
    with pytest.raises(FrameConflictError) as err:
        tree.set_transform(ts("map", "base_link", 2.0), authority="amcl")
    assert str(err.value) == (
        "frame 'base_link' already has parent 'odom'; 'amcl' gives it parent 'map': a frame "
        "has exactly one parent (REP-105 chain map -> odom -> base_link); stop one of the two "
        "publishers")
    with pytest.raises(FrameConflictError, match=r"would close a loop: 'base_link' already "
                                                 r"descends from 'map'"):
        tree.set_transform(ts("base_link", "map", 2.0))
    with pytest.raises(FrameConflictError) as err:
        tree.set_transform(ts("odom", "base_link", 6.0), is_static=True)
    assert str(err.value) == ("edge odom->base_link is dynamic (/tf) but a static (/tf_static) "
                              "transform arrived for it; publish each frame on one of /tf or "
                              "/tf_static")
    with pytest.raises(InvalidMessage, match=r"contains NaN or inf"):
        tree.set_transform(ts("odom", "base_link", 6.0, math.nan))
    bad_q = TransformStamped(Header(6.0, "odom"), "base_link",
                             Transform(Vector3(), Quaternion(0.0, 0.0, 0.0, 0.5)))
    with pytest.raises(InvalidMessage) as ierr:
        tree.set_transform(bad_q)
    assert str(ierr.value) == ("transform odom->base_link at t=6.000 s has a non-unit rotation "
                               "quaternion (|q|^2 = 0.2500); normalise it (tf2 tolerance 0.01)")
    with pytest.raises(InvalidMessage, match=r"empty frame id"):
        tree.set_transform(ts("", "x", 1.0))
    assert tree.latest_time("base_link") == 5.0  # nothing above changed the buffer


def test_slightly_denormalised_quaternion_is_renormalised() -> None:
    tree = TransformTree()
    h = math.sqrt(0.5) * 1.002
    tree.set_transform(TransformStamped(Header(0.0, "a"), "b",
                                        Transform(Vector3(), Quaternion(0.0, 0.0, h, h))))
    q = tree.lookup("a", "b", 0.0).transform.rotation
    assert (q.x, q.y, q.z, q.w) == pytest.approx((0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)))


def test_apply_tf_message_and_clear() -> None:
    tree = TransformTree()
    n = tree.apply_tf_message(TFMessage((ts("base_link", "laser", 0.0, 0.2),
                                         ts("base_link", "imu", 0.0))), is_static=True)
    assert n == 2
    assert tree.apply_tf_message(TFMessage((ts("odom", "base_link", 1.0, 1.0),)),
                                 is_static=False) == 1
    assert_pose(tree.lookup_pose2d("odom", "laser"), 1.2, 0.0, 0.0)
    tree.clear()
    assert tree.frames() == ["base_link", "imu", "laser"]
    assert_pose(tree.lookup_pose2d("base_link", "laser"), 0.2, 0.0, 0.0)


def test_one_bad_transform_does_not_drop_the_rest_of_a_message() -> None:
    tree = TransformTree()
    msg = TFMessage((ts("odom", "base_link", 1.0, math.inf), ts("map", "odom", 1.0, 2.0)))
    with pytest.raises(InvalidMessage, match=r"odom->base_link at t=1\.000 s contains NaN"):
        tree.apply_tf_message(msg, is_static=False)
    assert tree.frames() == ["map", "odom"]
    assert_pose(tree.lookup_pose2d("map", "odom", 1.0), 2.0, 0.0, 0.0)


# --- consistency checks ----------------------------------------------------------------------
def test_check_chain() -> None:
    tree = rep105_tree()
    chain = ["map", "odom", "base_link", "laser"]
    assert check_chain(tree, chain, 2.5) == []
    assert check_chain(tree, chain, None) == []
    assert check_chain(tree, chain, 6.0) == [
        "lookup of 'odom' in 'map' at t=6.000 s would extrapolate into the future: "
        "edge map->odom holds [0.000, 5.000] s",
        "lookup of 'base_link' in 'odom' at t=6.000 s would extrapolate into the future: "
        "edge odom->base_link holds [0.000, 5.000] s",
    ]
    assert check_chain(tree, ["map", "odom", "base_link", "lidar"], 1.0) == [
        "frame 'lidar' does not exist (did you mean 'laser'?); known frames: base_link, imu, "
        "laser, map, odom"]


def test_check_chain_flags_rep105_violation_and_disjoint_windows() -> None:
    tree = TransformTree()
    tree.add_static("map", "odom", Pose2D())
    tree.set_transform(ts("map", "base_link", 1.0))  # AMCL-style shortcut: skips odom
    assert check_chain(tree, ["map", "odom", "base_link"], 1.0) == [
        "'odom' is not the parent of 'base_link' (its parent is 'map'); "
        "expected chain map -> odom -> base_link"]
    tree2 = TransformTree()
    tree2.set_transform(ts("map", "odom", 0.0))
    tree2.set_transform(ts("map", "odom", 1.0))
    tree2.set_transform(ts("odom", "base_link", 2.0))
    assert check_chain(tree2, ["map", "odom", "base_link"], None) == [
        "lookup of 'base_link' in 'map' at t=1.000 s (latest common time) would extrapolate "
        "into the past: edge odom->base_link holds [2.000, 2.000] s"]


def jumpy_samples() -> list[TransformStamped]:
    """10 Hz odometry moving 0.1 m per step; a 2 m jump at t=3.0 and a 1 rad turn at t=4.0."""
    out = []
    for k in range(51):
        t = k / 10.0
        x = 0.1 * k + (2.0 if k >= 30 else 0.0)
        yaw = 1.0 if k >= 40 else 0.0
        out.append(ts("odom", "base_link", t, x, 0.0, yaw))
    return out


def test_find_jumps() -> None:
    samples = jumpy_samples()
    jumps = find_jumps(samples, max_linear=0.5, max_angular=0.5)
    assert len(jumps) == 2
    assert jumps[0] == pytest.approx((3.0, 2.1, 0.0), abs=1e-12)
    assert jumps[1] == pytest.approx((4.0, 0.1, 1.0), abs=1e-12)
    shuffled = samples[:]
    random.Random(3).shuffle(shuffled)
    assert find_jumps(shuffled, 0.5, 0.5) == jumps
    assert find_jumps(samples, 0.5, 0.5, declared_resets=[3.0]) == [jumps[1]]
    assert find_jumps(samples, 0.5, 0.5, declared_resets=[2.95, 3.95]) == []
    assert find_jumps(samples, 0.5, 0.5, declared_resets=[2.9]) == jumps  # before the step
    assert find_jumps(samples, 5.0, 5.0) == []
    assert find_jumps(samples[:1], 0.0, 0.0) == []


def test_find_jumps_measures_3d_rotation_and_refuses_mixed_edges() -> None:
    samples = [ts_rpy("base_link", "imu", 0.0, 0.0, 0.0, 0.0),
               ts_rpy("base_link", "imu", 0.1, 0.8, 0.0, 0.0)]
    assert find_jumps(samples, 1.0, 0.5) == [pytest.approx((0.1, 0.0, 0.8), abs=1e-12)]
    with pytest.raises(InvalidMessage) as err:
        find_jumps([ts("map", "odom", 0.0), ts("odom", "base_link", 0.0)], 1.0, 1.0)
    assert str(err.value) == ("find_jumps needs samples of one edge; got map->odom, "
                              "odom->base_link")

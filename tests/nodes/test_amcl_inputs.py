"""AmclNode on a hand-driven bus: update gating, TF output, services and bad input.

A still robot at (2.0, 1.5, 0.3) in a 6 m x 4 m room with a pillar; odometry reads the
identity, so the true ``map -> odom`` is the robot pose itself.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.msgs import (
    Header,
    LaserScan,
    OccupancyGrid,
    Pose2D,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    TFMessage,
    Transform,
    TransformStamped,
)
from navstack.localization.amcl import AmclMapError, AmclParams
from navstack.nodes.amcl import AmclNode
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Runtime
from navstack.sim.world import World

TRUTH = Pose2D(2.0, 1.5, 0.3)
BEAMS = 360


def _world() -> World:
    occ = np.zeros((80, 120), bool)
    occ[:2, :] = occ[-2:, :] = True
    occ[:, :2] = occ[:, -2:] = True
    occ[50:60, 80:86] = True  # a pillar breaks the symmetry
    return World(occ, 0.05)


class Rig:
    """Runtime + AMCL + publishers for map, TF, scans and initial poses."""

    def __init__(self, **params: object) -> None:
        self.world = _world()
        self.rt = Runtime()
        self.amcl = AmclNode(self.rt, AmclParams(base_frame_id="base_link", **params),
                             rng=np.random.default_rng(0))
        bus = self.rt.bus
        self.map_pub = bus.publisher("/map", OccupancyGrid, LATCHED)
        self.tf_pub = bus.publisher("/tf", TFMessage, QoS(depth=100))
        self.scan_pub = bus.publisher("/scan", LaserScan)
        self.pose_pub = bus.publisher("/initialpose", PoseWithCovarianceStamped)
        self.map_odom: list[tuple[float, Pose2D]] = []
        bus.subscribe("/tf", TFMessage, lambda m: self.map_odom.extend(
            (t.header.stamp, t.transform.to_pose2d()) for t in m.transforms
            if t.header.frame_id == "map"), QoS(depth=100))
        bus.publisher("/tf_static", TFMessage, QoS(depth=1, latched=True)).publish(TFMessage((
            TransformStamped(Header(0.0, "base_link"), "laser", Transform()),)))
        self.map_pub.publish(self.world.to_occupancy_grid())
        self.rt.bring_up()
        self.rt.scheduler.run_until(0.0)

    def scan(self, t: float, ranges: np.ndarray | None = None, stamp: float | None = None
             ) -> None:
        """At time ``t``: odometry (identity) at ``t``, then a scan stamped ``stamp``."""
        self.rt.scheduler.run_until(t)
        self.tf_pub.publish(TFMessage((TransformStamped(Header(t, "odom"), "base_link",
                                                        Transform()),)))
        angles = -math.pi + np.arange(BEAMS) * (2 * math.pi / BEAMS)
        if ranges is None:
            ranges = self.world.cast_rays(TRUTH.x, TRUTH.y, TRUTH.theta, angles, 0.1, 12.0, t)
        self.scan_pub.publish(LaserScan(
            Header(t if stamp is None else stamp, "laser"), -math.pi, math.pi,
            2 * math.pi / BEAMS, 0.0, 0.1, 0.1, 12.0, np.asarray(ranges, np.float32)))
        self.rt.scheduler.run_until(t + 0.01)


def test_updates_tf_and_nomotion_service() -> None:
    rig = Rig()
    amcl = rig.amcl
    rig.scan(0.1)
    assert amcl.scans_without_pose == 1 and amcl.updates == 0
    assert amcl.last_problem == ("no initial pose: publish /initialpose, call /set_initial_pose "
                                 "or /reinitialize_global_localization")
    amcl.set_initial_pose(TRUTH.x, TRUTH.y, TRUTH.theta, np.diag([0.01, 0.01, 0.005]))
    rig.scan(0.2)
    assert amcl.updates == 1  # first scan after initialisation: update without motion
    assert amcl.estimate == pytest.approx([TRUTH.x, TRUTH.y, TRUTH.theta], abs=0.05)
    # map -> odom at the scan stamp, then future-dated by transform_tolerance (1 s)
    assert [round(s, 6) for s, _ in rig.map_odom] == [0.2, 1.2]
    p = rig.map_odom[-1][1]
    assert math.hypot(p.x - TRUTH.x, p.y - TRUTH.y) < 0.05
    rig.scan(0.3)  # no motion: no update, the transform is re-sent with a new expiry
    assert amcl.updates == 1 and round(rig.map_odom[-1][0], 6) == 1.3
    assert rig.rt.bus.call("/request_nomotion_update", {}) == {"result": True}
    rig.scan(0.4)
    assert amcl.updates == 2 and len(amcl.update_ms) == 2
    located = rig.rt.tf.lookup_pose2d("map", "laser", 0.4)
    assert math.hypot(located.x - TRUTH.x, located.y - TRUTH.y) < 0.05


def test_nan_and_inf_ranges_are_skipped_beams() -> None:
    rig = Rig()
    rig.amcl.set_initial_pose(TRUTH.x, TRUTH.y, TRUTH.theta, np.diag([0.01, 0.01, 0.005]))
    angles = -math.pi + np.arange(BEAMS) * (2 * math.pi / BEAMS)
    ranges = rig.world.cast_rays(TRUTH.x, TRUTH.y, TRUTH.theta, angles, 0.1, 12.0, 0.0)
    ranges[::12] = np.nan  # every second subsampled beam (step 6)
    ranges[6::24] = np.inf
    ranges[18::24] = -np.inf
    rig.scan(0.2, ranges)
    amcl = rig.amcl
    assert amcl.updates == 1 and amcl.invalid_beams == 45  # 30 NaN + 15 -inf
    assert np.isfinite(amcl.estimate).all()
    assert amcl.estimate[:2] == pytest.approx([TRUTH.x, TRUTH.y], abs=0.05)
    rig.scan(0.3, np.full(BEAMS, np.nan))  # a scan of nothing: no crash, no information
    assert np.isfinite(amcl.filter.pf.weights).all()


def test_bad_initial_poses_are_rejected_and_counted() -> None:
    rig = Rig()
    amcl = rig.amcl
    amcl.set_initial_pose(TRUTH.x, TRUTH.y, TRUTH.theta)
    rig.scan(0.2)
    before = amcl.filter.pf.poses.copy()
    cov = np.zeros((6, 6))
    cov[0, 0] = cov[1, 1] = 0.25
    cov[5, 5] = 0.07
    nan_pose = Pose2D(math.nan, 1.5, 0.0).to_pose()
    rig.pose_pub.publish(PoseWithCovarianceStamped(Header(0.2, "map"),
                                                   PoseWithCovariance(nan_pose, cov)))
    rig.rt.scheduler.run_until(0.25)
    assert amcl.rejected_initial_poses == 1
    assert amcl.last_rejection == ("/initialpose rejected: initial pose must be 3 finite "
                                   "numbers (x, y, yaw), got [nan, 1.5, 0.0]")
    rig.pose_pub.publish(PoseWithCovarianceStamped(
        Header(0.2, "odom"), PoseWithCovariance(TRUTH.to_pose(), cov)))
    rig.rt.scheduler.run_until(0.27)
    assert amcl.rejected_initial_poses == 2
    assert amcl.last_rejection == ("/initialpose rejected: frame 'odom' is not the global "
                                   "frame 'map'; initial poses must be given in the global "
                                   "frame")
    reply = rig.rt.bus.call("/set_initial_pose", {"x": 1.0, "y": 1.0, "yaw": 0.0,
                                                  "covariance": np.full((3, 3), np.nan)})
    assert reply == {"result": False, "reason": "/set_initial_pose rejected: initial "
                                                "covariance has NaN or infinite entries"}
    assert amcl.rejected_initial_poses == 3
    assert np.array_equal(amcl.filter.pf.poses, before)  # filter state intact
    # a good /initialpose re-seeds the filter (6x6 covariance: x, y, yaw entries)
    good = Pose2D(3.0, 2.0, 0.0)
    rig.pose_pub.publish(PoseWithCovarianceStamped(Header(0.3, "map"),
                                                   PoseWithCovariance(good.to_pose(), cov)))
    rig.rt.scheduler.run_until(0.35)
    assert amcl.rejected_initial_poses == 3
    assert amcl.filter.pf.poses[:, 0].mean() == pytest.approx(3.0, abs=0.05)
    assert rig.rt.bus.call("/set_initial_pose", {"x": 2.0, "y": 1.5, "yaw": 0.3}) == \
        {"result": True}


def test_out_of_order_scans_are_dropped_and_counted() -> None:
    rig = Rig()
    rig.amcl.set_initial_pose(TRUTH.x, TRUTH.y, TRUTH.theta)
    rig.scan(1.0)
    rig.scan(1.1, stamp=0.9)
    rig.scan(1.2, stamp=1.0)
    amcl = rig.amcl
    assert amcl.scans_out_of_order == 2 and amcl.updates == 1
    assert amcl.last_problem == ("scan at t=1.000 dropped: not newer than the previous scan "
                                 "(t=1.000); scans must arrive in stamp order")


def test_scans_wait_for_odometry_then_time_out() -> None:
    rig = Rig(transform_tolerance=0.5)
    amcl = rig.amcl
    amcl.set_initial_pose(TRUTH.x, TRUTH.y, TRUTH.theta)
    rig.scan(0.2)
    rig.scan(0.4, stamp=0.45)  # odometry only up to 0.4: the scan waits ...
    assert amcl.scans_received == 2 and amcl.tf_failures == 0
    rig.rt.scheduler.run_until(1.0)  # ... and is dropped after transform_tolerance
    assert amcl.tf_failures == 1
    assert amcl.last_problem.startswith("scan at t=0.450 dropped: ")


def test_maps_and_global_localization() -> None:
    rt = Runtime()
    amcl = AmclNode(rt, AmclParams(first_map_only=True), rng=np.random.default_rng(1))
    rt.bring_up()
    reply = rt.bus.call("/reinitialize_global_localization", {})
    assert reply == {"result": False, "reason": (
        "no map yet: global localization samples the free space of the map on 'map'; "
        "publish it first")}
    with pytest.raises(AmclMapError):
        amcl.global_localization()
    pub = rt.bus.publisher("/map", OccupancyGrid, LATCHED)
    bad = OccupancyGrid(Header(0.0, "map"), _world().to_occupancy_grid().info,
                        np.zeros((3, 3), np.int8))
    pub.publish(bad)
    rt.scheduler.run_until(0.1)
    assert amcl.maps_rejected == 1 and amcl.last_problem.startswith("map rejected: map is 120")
    pub.publish(_world().to_occupancy_grid())
    rt.scheduler.run_until(0.2)
    pub.publish(_world().to_occupancy_grid())
    rt.scheduler.run_until(0.3)
    assert (amcl.maps_received, amcl.maps_ignored) == (1, 1)  # first_map_only
    amcl.global_localization()
    xy = amcl.filter.pf.poses[:, :2]
    assert len(xy) == 2000 and xy.min() > 0.05 and xy[:, 0].max() < 5.95
    assert amcl.initial_pose_known


def test_set_initial_pose_parameter_and_lifecycle() -> None:
    rig = Rig(set_initial_pose=True, initial_pose={"x": 2.0, "y": 1.5, "yaw": 0.3})
    amcl = rig.amcl
    assert amcl.initial_pose_known
    assert amcl.filter.pf.poses.mean(axis=0)[:2] == pytest.approx([2.0, 1.5], abs=0.05)
    rig.scan(0.2)
    assert amcl.updates == 1 and amcl.saved_pose is not None
    amcl.deactivate()
    amcl.cleanup()
    assert not amcl.initial_pose_known and "/set_initial_pose" not in rig.rt.bus.services

"""AmclNode in the simulated office: tracking, global localization, kidnapping, KLD.

The simulator runs with ``perfect_localization=False`` (no map -> odom from it) and noisy
wheel odometry; AMCL gets the true map on ``/map``.  Runs are deterministic per seed.
"""

from __future__ import annotations

import math

import numpy as np

from navstack.core.msgs import (
    LaserScan,
    OccupancyGrid,
    Odometry,
    Pose2D,
    PoseArray,
    PoseWithCovarianceStamped,
    TFMessage,
    Twist,
)
from navstack.localization.amcl import AmclParams
from navstack.nodes.amcl import AmclNode
from navstack.runtime.bus import LATCHED
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.open_loop import build_sim

ROOM_A = (2.5, 4.0, 0.0)
ROOM_C = (12.5, 3.0, 0.0)


def _stack(seed: int, params: AmclParams, vx: float, wz: float,
           start: tuple[float, float, float] | None = None
           ) -> tuple[Runtime, SimulatorNode, AmclNode]:
    rt, sim = build_sim("office", "diff_drive", seed, perfect_localization=False)
    if start is not None:
        sim.sim.teleport(Pose2D(*start))
    rt.bus.publisher("/map", OccupancyGrid, LATCHED).publish(sim.sim.world.to_occupancy_grid())
    amcl = AmclNode(rt, params, rng=np.random.default_rng(seed))
    cmd = rt.bus.publisher("/cmd_vel", Twist)
    rt.scheduler.create_timer(0.05, lambda: cmd.publish(Twist.planar(vx, 0.0, wz)), 0.0)
    rt.bring_up()
    return rt, sim, amcl


def _error(rt: Runtime, sim: SimulatorNode) -> float:
    """Distance between map -> base_link (AMCL + odometry, now) and the true pose."""
    sim.advance()
    p = rt.tf.lookup_pose2d("map", "base_link")
    return math.hypot(p.x - sim.sim.pose.x, p.y - sim.sim.pose.y)


def test_tracking_from_a_known_pose_stays_within_10_cm() -> None:
    params = AmclParams(base_frame_id="base_link")
    rt, sim, amcl = _stack(0, params, vx=0.4, wz=0.0)
    truth: dict[float, Pose2D] = {}
    rt.bus.subscribe("/ground_truth", Odometry, lambda m: truth.__setitem__(
        m.header.stamp, m.pose.pose.to_pose2d()))
    poses: list[PoseWithCovarianceStamped] = []
    rt.bus.subscribe("/amcl_pose", PoseWithCovarianceStamped, poses.append)
    scans: list[float] = []
    rt.bus.subscribe("/scan", LaserScan, lambda m: scans.append(m.header.stamp))
    map_odom: list[float] = []
    rt.bus.subscribe("/tf", TFMessage, lambda m: map_odom.extend(
        t.header.stamp for t in m.transforms if t.header.frame_id == "map"))
    clouds: list[int] = []
    rt.bus.subscribe("/particle_cloud", PoseArray, lambda m: clouds.append(len(m.poses)))
    spawn = sim.sim.world.spawn
    amcl.set_initial_pose(spawn.x, spawn.y, spawn.theta)
    rt.scheduler.run_until(30.0)

    assert sim.sim.pose.x > spawn.x + 10.0  # drove ~12 m down the corridor
    assert amcl.updates >= 40 and len(poses) >= 40 and clouds[0] == 2000
    errors = []
    for msg in poses:
        t = min(truth, key=lambda s: abs(s - msg.header.stamp))
        p, q = msg.pose.pose.to_pose2d(), truth[t]
        errors.append(math.hypot(p.x - q.x, p.y - q.y))
        cov = msg.pose.covariance
        assert cov[0, 0] > 0 and cov[1, 1] > 0 and cov[5, 5] > 0 and cov[2, 2] == 0.0
    assert max(errors) < 0.1
    assert _error(rt, sim) < 0.1
    # map -> odom: the first at the scan stamp, then every scan's stamp + transform_tolerance
    assert map_odom[0] in scans
    assert all(any(abs(s + 1.0 - t) < 1e-9 for s in scans) for t in map_odom[1:])
    assert len(map_odom) >= 0.9 * len(scans)
    assert np.isfinite(amcl.estimate).all() and amcl.covariance.shape == (3, 3)


def test_global_localization_in_room_c_and_kld_shrinks_the_set() -> None:
    """Uniform particles over the office (5000), robot turning on the spot in room C.
    Seeds 0-4 all converge (at 9.5, 21.5, 13, 8.5, 11 s); seed 0 is checked here."""
    params = AmclParams(base_frame_id="base_link", max_particles=5000)
    rt, sim, amcl = _stack(0, params, vx=0.0, wz=0.5, start=ROOM_C)
    rt.scheduler.run_until(0.05)  # the latched map arrives
    reply = rt.bus.call("/reinitialize_global_localization", {})
    assert reply == {"result": True, "particles": 5000}
    converged_at = None
    for k in range(1, 61):
        rt.scheduler.run_until(0.5 * k)
        error = _error(rt, sim)
        if error < 0.3 and converged_at is None:
            converged_at = 0.5 * k
        elif error >= 0.3:
            converged_at = None
    assert converged_at is not None and converged_at <= 15.0
    assert _error(rt, sim) < 0.1
    assert amcl.particle_count <= 600  # KLD: 500 (min_particles) + 1 once converged
    assert max(amcl.update_ms) < 100.0 and len(amcl.update_ms) == amcl.updates


def _kidnap(recovery: bool) -> tuple[float, float, int]:
    alphas = {"recovery_alpha_slow": 0.01, "recovery_alpha_fast": 0.1} if recovery else {}
    params = AmclParams(base_frame_id="base_link", max_particles=5000, **alphas)
    rt, sim, amcl = _stack(0, params, vx=0.0, wz=0.5, start=ROOM_C)
    amcl.set_initial_pose(*ROOM_C)
    rt.scheduler.run_until(40.0)
    before = _error(rt, sim)
    assert amcl.filter.pf.injected_total == 0  # no spurious injection while tracking
    sim.sim.teleport(Pose2D(*ROOM_A))  # odometry does not see this
    rt.scheduler.run_until(100.0)
    return before, _error(rt, sim), amcl.filter.pf.injected_total


def test_kidnapped_robot_is_recovered_through_recovery_alphas() -> None:
    """Tracked in room C for 40 s, then carried to room A (10 m away).  With
    recovery_alpha_slow/fast = 0.01/0.1 the w_fast/w_slow shortfall injects uniform
    particles and the filter re-localizes within the next 60 s (seeds 0-4: after 26.5,
    36.5, 30.5, 38.5, 29 s); with recovery off it stays lost."""
    before, after, injected = _kidnap(recovery=True)
    assert before < 0.1 and after < 0.3 and injected > 1000
    before, after, injected = _kidnap(recovery=False)
    assert before < 0.1 and after > 5.0 and injected == 0

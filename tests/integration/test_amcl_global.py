"""AMCL global localization and kidnap recovery in the office, driven by the bench's
reactive wander (the bench runs 20 and 5 trials; these are two of them)."""

from __future__ import annotations

import math

import numpy as np

from navstack.benchmarks import localization as bench
from navstack.sim.simulator import RobotState


def _trial(spawn: tuple[float, float, float], seed: int, params: dict[str, object]
           ) -> tuple[object, object, object]:
    rt, sim, amcl = bench._amcl_sim(seed, spawn, params)
    bench.Wander(rt)
    rt.bring_up()
    return rt, sim, amcl


def test_global_localization_from_uniform_particles_converges_within_30_s() -> None:
    # spawn 4 of the bench: in the corridor, where a look-alike hypothesis wins at first
    spawn = (5.53, 7.62, -2.92)
    rt, sim, amcl = _trial(spawn, 104, {})
    rt.scheduler.run_until(0.2)
    amcl.global_localization()
    t = bench._converge_time(rt, sim, amcl, rt.now, 30.0)
    assert t <= 30.0, "did not converge (and stay converged for 5 s) within 30 s"
    assert sim.sim.collisions == 0


def test_kidnapped_robot_is_found_again() -> None:
    # tracked for 40 s in room F, then carried to room D (seeded: the same run every time)
    rng = np.random.default_rng(11)
    starts, targets = bench._free_poses(rng, 2), bench._free_poses(rng, 2)
    start, target = starts[1], targets[1]
    params = {"set_initial_pose": True,
              "initial_pose": {"x": start[0], "y": start[1], "yaw": start[2]}}
    rt, sim, amcl = _trial(start, 201, params)
    rt.scheduler.run_until(bench.KIDNAP_AFTER_S)
    sim.advance()
    assert bench._error(amcl, sim)[0] < 0.2  # tracking before the kidnap
    sim.sim.state = RobotState(x=target[0], y=target[1], yaw=target[2])
    t = bench._converge_time(rt, sim, amcl, rt.now, 30.0)
    assert not math.isnan(t), "not recovered within 30 s of the kidnap"

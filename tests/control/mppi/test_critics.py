"""Each MPPI critic against hand-computed scores on hand-built batches."""

from __future__ import annotations

import math

import numpy as np

from navstack.control.mppi.critics import CRITICS, Critic, CriticData, RobotShape
from navstack.control.mppi.critics.collision import inflation_cost
from navstack.control.mppi.critics.path import furthest_reached_point
from navstack.control.mppi.models import (
    AckermannMotionModel,
    DiffDriveMotionModel,
    MotionModel,
    OmniMotionModel,
)
from navstack.control.mppi.params import MPPIParams
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D

T, B, DT = 20, 3, 0.05


def _critic(name: str, model: MotionModel | None = None, shape: RobotShape | None = None,
            **section: object) -> Critic:
    params = MPPIParams.from_mapping({name: section, "critics": [name]})
    return CRITICS[name](CRITICS[name].params_model.from_mapping(section), params,
                         model or DiffDriveMotionModel(),
                         shape or RobotShape.from_footprint(None))


def _data(traj: np.ndarray | None = None, controls: np.ndarray | None = None,
          init: tuple[float, float, float] = (0.0, 0.0, 0.0), goal_distance: float = 5.0,
          path: np.ndarray | None = None, costmap: Costmap2D | None = None,
          arc: np.ndarray | None = None) -> CriticData:
    traj = np.zeros((3, T, B), np.float32) if traj is None else traj.astype(np.float32)
    controls = (np.zeros((3, T, B), np.float32) if controls is None
                else controls.astype(np.float32))
    cm = costmap or Costmap2D(100, 100, 0.1, -5.0, -5.0)
    path = np.zeros((0, 3)) if path is None else path
    return CriticData(np.array([0.0, 0.0, 0.0, *init]), controls, traj,
                      np.zeros(traj.shape[2]) if arc is None else arc, np.zeros(traj.shape[2]),
                      DT, DiffDriveMotionModel(), path, np.ones(len(path), dtype=bool),
                      np.array([goal_distance, 0.0, 0.0]), goal_distance, cm, False)


def _constant_controls(vx: float, vy: float = 0.0, wz: float = 0.0) -> np.ndarray:
    c = np.zeros((3, T, B))
    c[0], c[1], c[2] = vx, vy, wz
    return c


def test_constraint_critic_per_motion_model() -> None:
    d = _data(controls=_constant_controls(0.6), init=(0.6, 0.0, 0.0))
    _critic("ConstraintCritic").score(d)
    np.testing.assert_allclose(d.costs, 0.1 * T * DT * 4.0, rtol=1e-5)
    d = _data(controls=_constant_controls(-0.45), init=(-0.45, 0.0, 0.0))
    _critic("ConstraintCritic", cost_power=2).score(d)
    np.testing.assert_allclose(d.costs, (0.1 * T * DT * 4.0) ** 2, rtol=1e-5)
    d = _data(controls=_constant_controls(0.3, 0.7), init=(0.3, 0.7, 0.0))
    _critic("ConstraintCritic", OmniMotionModel()).score(d)
    np.testing.assert_allclose(d.costs, 0.2 * T * DT * 4.0, rtol=1e-5)
    d = _data(controls=_constant_controls(1.0, 0.0, 1.0), init=(1.0, 0.0, 1.0))
    _critic("ConstraintCritic", AckermannMotionModel(5.0)).score(d)
    # vx 1.0 > vx_max 0.5 by 0.5, radius 1 m short of 5 m by 4: (0.5 + 4) per step
    np.testing.assert_allclose(d.costs, 4.5 * T * DT * 4.0, rtol=1e-5)


def test_prefer_forward_twirling_and_deadband() -> None:
    d = _data(controls=_constant_controls(-0.2), init=(-0.2, 0.0, 0.0))
    _critic("PreferForwardCritic").score(d)
    np.testing.assert_allclose(d.costs, 0.2 * T * DT * 5.0, rtol=1e-5)
    near = _data(controls=_constant_controls(-0.2), init=(-0.2, 0.0, 0.0), goal_distance=0.3)
    _critic("PreferForwardCritic").score(near)
    assert np.all(near.costs == 0.0)
    d = _data(controls=_constant_controls(0.0, 0.0, -0.5), init=(0.0, 0.0, -0.5))
    _critic("TwirlingCritic").score(d)
    np.testing.assert_allclose(d.costs, 0.5 * 10.0, rtol=1e-5)
    d = _data(controls=_constant_controls(0.02, 0.0, 0.0), init=(0.02, 0.0, 0.0))
    _critic("VelocityDeadbandCritic", deadband_velocities=[0.05, 0.05, 0.05]).score(d)
    np.testing.assert_allclose(d.costs, (0.03 + 0.05) * T * DT * 35.0, rtol=1e-5)


def test_goal_critics() -> None:
    traj = np.zeros((3, T, B))
    ang = np.linspace(0.0, 2.0, T)
    traj[0] = (1.0 + np.cos(ang))[:, None]  # every pose 1 m from the goal at (1, 0)
    traj[1] = np.sin(ang)[:, None]
    traj[2] = 0.3
    d = _data(traj, goal_distance=1.0)
    d.goal[:] = (1.0, 0.0, 0.0)
    d.path = np.array([[1.0, 0.0, 0.0]])
    _critic("GoalCritic").score(d)
    np.testing.assert_allclose(d.costs, 5.0, rtol=1e-5)
    d.costs[:] = 0.0
    _critic("GoalAngleCritic", threshold_to_consider=1.5).score(d)
    np.testing.assert_allclose(d.costs, 0.3 * 3.0, rtol=1e-5)
    d.costs[:] = 0.0
    d.trajectories[2] = math.pi - 0.2 + 2 * math.pi  # unwrapped, almost backwards
    _critic("GoalAngleCritic", threshold_to_consider=1.5, symmetric_yaw_tolerance=True).score(d)
    np.testing.assert_allclose(d.costs, 0.2 * 3.0, rtol=1e-4)
    far = _data(traj, goal_distance=2.0)
    _critic("GoalCritic").score(far)
    assert np.all(far.costs == 0.0)


def test_cost_critic_scores_and_collisions() -> None:
    cm = Costmap2D(100, 100, 0.1, -5.0, -5.0)
    cm.data[:, :] = 100
    traj = np.zeros((3, T, B))
    traj[0] = np.linspace(0.0, 1.0, T)[:, None]
    d = _data(traj, costmap=cm)
    _critic("CostCritic").score(d)
    np.testing.assert_allclose(d.costs, 100.0 * 3.81 / 254.0, rtol=1e-9)
    # near the goal only critical costs count
    near = _data(traj, costmap=cm, goal_distance=0.2)
    _critic("CostCritic").score(near)
    assert np.all(near.costs == 0.0)
    # sample 1 crosses a lethal cell, sample 2 an inscribed one (critical for a point check)
    cm.data[50, 55] = 254  # x in [0.5, 0.6), y in [0, 0.1)
    traj[1, :, 2] = -0.5
    cm.data[44, 55] = 253
    d = _data(traj, costmap=cm)
    _critic("CostCritic").score(d)
    n = T // 2
    assert math.isclose(d.costs[0], 1e6 * 3.81 / 254.0 / n, rel_tol=1e-9)
    assert not d.fail
    traj[1] = 0.0
    d = _data(traj, costmap=cm)
    _critic("CostCritic").score(d)
    assert d.fail and d.failed_by == "CostCritic"


def test_cost_critic_off_map_is_a_collision_unless_unknown_is_tracked() -> None:
    traj = np.zeros((3, T, B))
    traj[0] = np.linspace(4.0, 6.0, T)[:, None]  # leaves the 10 m map at x = 5
    d = _data(traj)
    _critic("CostCritic").score(d)
    assert d.fail
    d = _data(traj)
    d.track_unknown = True
    _critic("CostCritic").score(d)
    assert not d.fail
    # 255 counts as critical (>= near_collision_cost) for the poses past the edge
    n_off = int(np.sum(np.linspace(4.0, 6.0, T)[::2] >= 5.0))
    np.testing.assert_allclose(d.costs, n_off * 300.0 * 3.81 / 254.0 / (T // 2), rtol=1e-9)


def test_footprint_check_above_the_circumscribed_cost() -> None:
    fp = RobotShape.from_footprint(Footprint.from_polygon(
        [[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]]))
    critic = _critic("CostCritic", shape=fp, consider_footprint=True, inflation_radius=0.55,
                     cost_scaling_factor=10.0)
    circ = math.hypot(0.3, 0.2)
    assert critic.possible == inflation_cost(circ, 0.2, 10.0) == math.floor(
        252.0 * math.exp(-10.0 * (circ - 0.2)))
    cm = Costmap2D(100, 100, 0.1, -5.0, -5.0)
    cm.data[:, :] = int(critic.possible)  # high enough to need a footprint check
    cm.data[52, 50] = 254  # under the footprint's left edge (y = 0.2..0.3) at x = 0
    traj = np.zeros((3, T, B))
    d = _data(traj, costmap=cm)
    critic.score(d)
    assert d.fail
    cm.data[:, :] = int(critic.possible) - 1  # below: the point cost is trusted
    cm.data[52, 50] = 254
    d = _data(traj, costmap=cm)
    critic.score(d)
    assert not d.fail


def test_obstacles_critic_distance_terms() -> None:
    shape = RobotShape.from_footprint(Footprint.from_radius(0.2))
    critic = _critic("ObstaclesCritic", shape=shape)
    cm = Costmap2D(100, 100, 0.1, -5.0, -5.0)
    cm.data[:50, :] = 200  # y < 0: cost 200
    traj = np.zeros((3, T, B))
    traj[1, :, 0] = -1.0  # sample 0 in cost 200, samples 1 and 2 in free space
    d = _data(traj, costmap=cm)
    critic.score(d)
    dist = (10.0 * 0.2 - math.log(200.0) + math.log(253.0)) / 10.0 - 0.2
    raw = T * (0.1 - dist)
    repulsion = T * (0.55 - dist) / T
    np.testing.assert_allclose(d.costs, [20.0 * raw + 1.5 * repulsion, 0.0, 0.0], rtol=1e-5)
    cm.data[50, 50] = 254
    traj[1, :, 1] = 0.0
    d = _data(traj, costmap=cm)
    critic.score(d)
    assert math.isclose(d.costs[1], 20.0 * 100000.0, rel_tol=1e-9) and not d.fail


def _straight_path(n: int = 41, ds: float = 0.05) -> np.ndarray:
    x = np.arange(n) * ds
    return np.column_stack((x, np.zeros(n), np.zeros(n)))


def test_furthest_point_and_path_follow() -> None:
    path = _straight_path()
    traj = np.zeros((3, T, B))
    ends = (0.5, 1.0, 3.0)  # travelled lengths; the last overshoots the 2 m path
    for i, e in enumerate(ends):
        traj[0, :, i] = np.linspace(e / T, e, T)
    arc = np.array([e - e / T for e in ends])
    # sample 2 ends at x=3 but travelled 2.85 m: reaches the last point (index 40)
    assert furthest_reached_point(path, traj.astype(np.float32), arc) == 40
    # without it, sample 1 (end x=1.0, travelled 0.95 m -> bounded at 0.95) reaches 19
    assert furthest_reached_point(path, traj[:, :, :2].astype(np.float32), arc[:2]) == 19
    d = _data(traj[:, :, :2], path=path, arc=arc[:2])
    _critic("PathFollowCritic", offset_from_furthest=6).score(d)
    target = path[25, 0]
    np.testing.assert_allclose(d.costs, 5.0 * np.abs(np.array([0.5, 1.0]) - target),
                               rtol=1e-5)


def test_path_align_parallel_offset() -> None:
    path = _straight_path(61)
    traj = np.zeros((3, T, B))
    traj[0] = (np.arange(T) * 0.05)[:, None]  # from the path's start, at its spacing
    traj[1] = 0.1
    arc = np.full(B, 0.05 * (T - 1))
    d = _data(traj, path=path, arc=arc)
    _critic("PathAlignCritic", offset_from_furthest=5).score(d)
    np.testing.assert_allclose(d.costs, 0.1 * 10.0, rtol=1e-4)
    # distances are integrated from the first pose: a 0.05 m head start shows up too
    d = _data(traj + np.array([0.05, 0.0, 0.0])[:, None, None], path=path, arc=arc)
    _critic("PathAlignCritic", offset_from_furthest=5).score(d)
    np.testing.assert_allclose(d.costs, math.hypot(0.1, 0.05) * 10.0, rtol=1e-4)
    # blocked path (more than 7 % of the reached points invalid): the critic stands down
    d = _data(traj, path=path, arc=arc)
    d.path_valid[3:8] = False
    _critic("PathAlignCritic", offset_from_furthest=5).score(d)
    assert np.all(d.costs == 0.0)


def test_path_angle_critic() -> None:
    path = _straight_path()
    traj = np.zeros((3, T, B))
    traj[2, -1] = [0.0, 0.5, -1.0]  # end headings; ends at the origin, target ahead on +x
    d = _data(traj, path=path, arc=np.zeros(B))
    d.state[2] = math.pi  # robot faces away from the path: critic active
    _critic("PathAngleCritic").score(d)
    np.testing.assert_allclose(d.costs, 2.2 * np.array([0.0, 0.5, 1.0]), rtol=1e-5)
    d = _data(traj, path=path, arc=np.zeros(B))  # robot already aligned: inactive
    _critic("PathAngleCritic").score(d)
    assert np.all(d.costs == 0.0)

"""RPP single cycles with known answers: Nav2's regulation formulas, rotate to heading,
collision lookahead, limits and errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.rpp import (
    CollisionAhead,
    CostmapTooSmall,
    RegulatedPurePursuitController,
    RegulatedPurePursuitParams,
)
from navstack.control.rpp.collision import project_arc
from navstack.control.rpp.regulation import (
    approach_velocity_constraint,
    calculate_curvature,
    circle_segment_intersection,
    cost_constraint,
    curvature_constraint,
    find_velocity_sign_change,
    get_lookahead_point,
)
from navstack.core.errors import ConfigError, InvalidPath, NoValidControl
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.plugins import CONTROLLERS
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D

from .loop import straight_path


def _costmap(fill: int = 0) -> Costmap2D:
    cm = Costmap2D(80, 80, 0.05, -2.0, -2.0)
    cm.data[:] = fill
    return cm


def _ray(angle: float, length: float = 1.0) -> Path:
    """Two poses: the origin and a point ``length`` away at ``angle``."""
    return Path.from_array(np.array([[0.0, 0.0, angle], [length * math.cos(angle),
                                                         length * math.sin(angle), angle]]),
                           frame_id="map")


def test_curvature_and_velocity_regulation_on_a_ray() -> None:
    # carrot on the segment at exactly 0.6 m, direction 0.5 rad: kappa = 2 y / 0.36
    ctrl = RegulatedPurePursuitController()
    cmd = ctrl.compute(Pose2D(), Twist2D(), _ray(0.5), _costmap())
    kappa = 2.0 * 0.6 * math.sin(0.5) / 0.36
    assert ctrl.last_curvature == pytest.approx(kappa, rel=1e-12)
    radius = 1.0 / kappa  # 0.626 m < regulated_linear_scaling_min_radius 0.9
    v = 0.5 * (1.0 - (0.9 - radius) / 0.9)
    assert cmd.vx == pytest.approx(v, rel=1e-12)
    assert cmd.wz == pytest.approx(v * kappa, rel=1e-12)
    assert ctrl.last_carrot == pytest.approx((0.6 * math.cos(0.5), 0.6 * math.sin(0.5)))


def test_car_like_curvature_is_clamped_to_min_turning_radius() -> None:
    ctrl = RegulatedPurePursuitController({"use_rotate_to_heading": False,
                                           "min_turning_radius": 1.0})
    cmd = ctrl.compute(Pose2D(), Twist2D(), _ray(0.5), _costmap())
    kappa = 2.0 * 0.6 * math.sin(0.5) / 0.36
    v = 0.5 * (1.0 - (0.9 - 1.0 / kappa) / 0.9)  # regulation still sees the path curvature
    assert cmd.vx == pytest.approx(v, rel=1e-12)
    assert cmd.wz == pytest.approx(v * 1.0, rel=1e-12)  # |w / v| capped at 1 / 1.0 m


def test_cost_regulation_follows_the_nav2_formula() -> None:
    ctrl = RegulatedPurePursuitController(footprint=Footprint.from_radius(0.2))
    cmd = ctrl.compute(Pose2D(), Twist2D(), straight_path(3.0), _costmap(100))
    d = (3.0 * 0.2 - math.log(100.0) + math.log(253.0)) / 3.0  # 0.5094 m < 0.6
    assert cmd.vx == pytest.approx(0.5 * d / 0.6, rel=1e-12)
    assert cost_constraint(0.5, 100.0, 0.2, 0.6, 0.5, 3.0) == pytest.approx(
        0.5 * 0.5 * d / 0.6, rel=1e-12)
    assert cost_constraint(0.5, 0.0, 0.2, 0.6, 1.0, 3.0) == 0.5  # free: no regulation
    assert cost_constraint(0.5, 255.0, 0.2, 0.6, 1.0, 3.0) == 0.5  # unknown: none either
    assert cost_constraint(0.5, 20.0, 0.2, 0.6, 1.0, 3.0) == 0.5  # d = 1.04 m: far enough
    # floored at regulated_linear_scaling_min_speed
    cmd = ctrl.compute(Pose2D(), Twist2D(), straight_path(3.0), _costmap(250))
    assert cmd.vx == pytest.approx(0.25, rel=1e-12)


def test_approach_to_goal_slows_down() -> None:
    ctrl = RegulatedPurePursuitController()
    cm = Costmap2D(80, 80, 0.05, 1.0, -2.0)
    cmd = ctrl.compute(Pose2D(2.7, 0.0, 0.0), Twist2D(0.5), straight_path(3.0), cm)
    assert cmd.vx == pytest.approx(0.5 * 0.3 / 0.6, rel=1e-9)  # 0.3 m left of 0.6
    plan = np.array([[0.1, 0.0, 0.0], [0.2, 0.0, 0.0]])
    assert approach_velocity_constraint(0.5, plan, 0.05, 0.6) == pytest.approx(0.5 * 0.2 / 0.6)
    plan = np.array([[0.01, 0.0, 0.0], [0.05, 0.0, 0.0]])  # 0.0417 m/s: floored at 0.05
    assert approach_velocity_constraint(0.5, plan, 0.05, 0.6) == 0.05
    assert curvature_constraint(0.5, 0.0, 0.9) == 0.5


def test_rotate_to_heading_limits_acceleration_and_overshoot() -> None:
    ctrl = RegulatedPurePursuitController()
    path = straight_path(3.0)
    cmd = ctrl.compute(Pose2D(0.0, 0.0, math.pi / 2), Twist2D(), path, _costmap())
    assert (cmd.vx, cmd.wz) == (0.0, pytest.approx(-3.2 / 20.0))  # accel-limited from rest
    assert ctrl.is_rotating_to_heading
    cmd = ctrl.compute(Pose2D(0.0, 0.0, math.pi / 2), Twist2D(0.0, 0.0, -1.0), path, _costmap())
    assert cmd.wz == pytest.approx(-1.16)
    slow = RegulatedPurePursuitController({"max_angular_accel": 1.0})
    cmd = slow.compute(Pose2D(), Twist2D(0.0, 0.0, 1.8), _ray(0.8), _costmap())
    assert cmd.wz == pytest.approx(math.sqrt(2.0 * 1.0 * 0.8), rel=1e-9)  # stop in time


def test_rotates_to_goal_heading_at_the_end() -> None:
    path = Path.from_array(np.array([[2.0, 0.0, 0.0], [2.5, 0.0, 0.0], [3.0, 0.0, 1.0]]),
                           frame_id="map")
    ctrl = RegulatedPurePursuitController()
    cmd = ctrl.compute(Pose2D(2.9, 0.0, 0.0), Twist2D(), path, _costmap())
    assert (cmd.vx, cmd.wz) == (0.0, pytest.approx(0.16))
    # stateful: keeps rotating even after drifting out of the 0.25 m window
    cmd = ctrl.compute(Pose2D(2.6, 0.0, 0.5), Twist2D(0.0, 0.0, 0.16), path, _costmap())
    assert cmd.vx == 0.0 and cmd.wz == pytest.approx(0.32)


def test_collision_ahead_stops_with_a_reason() -> None:
    cm = Costmap2D(60, 40, 0.05, -1.0, -1.0)
    cm.data[:, 26] = 254  # x in [0.30, 0.35): across the path, 0.3 m ahead
    ctrl = RegulatedPurePursuitController()
    with pytest.raises(CollisionAhead) as err:
        ctrl.compute(Pose2D(0.01, 0.0, 0.0), Twist2D(0.5), straight_path(3.0), cm)
    assert isinstance(err.value, NoValidControl)
    assert str(err.value) == (
        "RegulatedPurePursuitController detected collision ahead: the robot centre would "
        "reach lethal cost 254 at (0.31, 0.00) in 0.60 s on the commanded arc (v 0.50 m/s, "
        "w 0.00 rad/s); replan around the obstacle")
    assert err.value.time == pytest.approx(0.6) and err.value.cost == 254
    with pytest.raises(CollisionAhead, match=r"the robot centre at \(0.31, 0.00\) is already"):
        ctrl.compute(Pose2D(0.31, 0.0, 0.0), Twist2D(0.5), straight_path(3.0), cm)
    # beyond the carrot (0.6 m) nothing is reported
    far = Costmap2D(60, 40, 0.05, -1.0, -1.0)
    far.data[:, 34] = 254  # x in [0.70, 0.75)
    assert ctrl.compute(Pose2D(0.01, 0.0, 0.0), Twist2D(0.5), straight_path(3.0),
                        far).vx == 0.5
    off = RegulatedPurePursuitController({"use_collision_detection": False})
    assert off.compute(Pose2D(0.01, 0.0, 0.0), Twist2D(0.5), straight_path(3.0), cm).vx == 0.5


def test_collision_arc_is_nav2s_euler_projection() -> None:
    arc = project_arc(Pose2D(0.0, 0.0, 0.0), 0.5, 0.5, 0.1, 1.0, 10.0)
    assert len(arc) == 9  # j * 0.1 < 1.0 for j = 1..9
    x = y = th = 0.0
    for j in range(9):
        x, y = x + 0.05 * math.cos(th), y + 0.05 * math.sin(th)
        th += 0.05
        np.testing.assert_allclose(arc[j], [x, y, th], atol=1e-12)
    assert len(project_arc(Pose2D(), 0.5, 0.0, 0.1, 1.0, 0.22)) == 4  # 0.2 m <= 0.22 < 0.25


def test_lookahead_helpers() -> None:
    ctrl = RegulatedPurePursuitController({"use_velocity_scaled_lookahead_dist": True})
    assert ctrl.lookahead_distance(Twist2D(0.4)) == pytest.approx(0.6)
    assert ctrl.lookahead_distance(Twist2D(0.1)) == 0.3
    assert ctrl.lookahead_distance(Twist2D(-1.0)) == 0.9
    assert calculate_curvature(1.0, 1.0) == pytest.approx(1.0)
    assert calculate_curvature(0.01, 0.01) == 0.0
    assert circle_segment_intersection((0.0, 0.0), (2.0, 0.0), 1.0) == pytest.approx((1.0, 0.0))
    plan = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
    assert get_lookahead_point(0.7, plan) == pytest.approx((0.7, 0.0))
    assert get_lookahead_point(0.7, plan, use_interpolation=False) == (1.0, 0.0)
    assert get_lookahead_point(1.5, plan) == (1.0, 0.0)
    assert get_lookahead_point(1.5, plan, interpolate_after_goal=True) == pytest.approx(
        (1.5, 0.0))
    cusp = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.5, 0.5, 0.0]])
    assert find_velocity_sign_change(cusp) == 2.0
    assert find_velocity_sign_change(plan) == math.inf


def test_speed_limit_and_cancel_deceleration() -> None:
    ctrl = RegulatedPurePursuitController({"use_cancel_deceleration": True})
    path, cm = straight_path(3.0), _costmap()
    ctrl.set_speed_limit(50.0, True)
    assert ctrl.compute(Pose2D(), Twist2D(), path, cm).vx == pytest.approx(0.25)
    ctrl.set_speed_limit(0.3, False)
    assert ctrl.compute(Pose2D(), Twist2D(), path, cm).vx == pytest.approx(0.3)
    ctrl.set_speed_limit(0.0, False)
    assert ctrl.compute(Pose2D(), Twist2D(), path, cm).vx == 0.5
    assert ctrl.cancel() is False
    assert ctrl.compute(Pose2D(), Twist2D(0.5), path, cm).vx == pytest.approx(0.5 - 3.2 / 20)
    assert ctrl.compute(Pose2D(), Twist2D(0.1), path, cm).vx == 0.0
    assert ctrl.cancel() is True
    ctrl.reset()
    assert ctrl.compute(Pose2D(), Twist2D(0.1), path, cm).vx == 0.5
    assert RegulatedPurePursuitController().cancel() is True


def test_errors_name_the_cause() -> None:
    ctrl = RegulatedPurePursuitController()
    with pytest.raises(InvalidPath, match="no plan"):
        ctrl.compute(Pose2D(), Twist2D(), None, _costmap())
    odom = Path.from_array(straight_path(1.0).as_array(), frame_id="odom")
    with pytest.raises(InvalidPath, match="plan is in frame 'odom' but the costmap is in 'map'"):
        ctrl.compute(Pose2D(), Twist2D(), odom, _costmap())
    with pytest.raises(InvalidPath, match="zero poses"):
        ctrl.compute(Pose2D(), Twist2D(), Path(), _costmap())
    with pytest.raises(CostmapTooSmall, match="is outside the costmap"):
        ctrl.compute(Pose2D(5.0, 0.0), Twist2D(), straight_path(6.0), _costmap())


def test_params_nav2_defaults_and_config_errors() -> None:
    p = RegulatedPurePursuitParams()
    assert (p.desired_linear_vel, p.lookahead_dist, p.min_lookahead_dist, p.max_lookahead_dist,
            p.lookahead_time, p.rotate_to_heading_angular_vel, p.rotate_to_heading_min_angle,
            p.max_angular_accel, p.cost_scaling_dist, p.inflation_cost_scaling_factor,
            p.regulated_linear_scaling_min_radius, p.regulated_linear_scaling_min_speed) == (
        0.5, 0.6, 0.3, 0.9, 1.5, 1.8, 0.785, 3.2, 0.6, 3.0, 0.9, 0.25)
    with pytest.raises(ConfigError) as err:
        RegulatedPurePursuitParams.from_mapping({"allow_reversing": True}, file="nav2.yaml",
                                                key_path="controller_server.FollowPath")
    assert str(err.value) == (
        "nav2.yaml: controller_server.FollowPath.allow_reversing: use_rotate_to_heading and "
        "allow_reversing cannot both be true: a robot that reverses along the path must not "
        "turn in place to face it (set use_rotate_to_heading: false to drive in reverse, or "
        "allow_reversing: false)")
    with pytest.raises(ConfigError, match="cannot rotate in place"):
        RegulatedPurePursuitController({"min_turning_radius": 2.0})
    with pytest.raises(ConfigError, match="needs use_fixed_curvature_lookahead"):
        RegulatedPurePursuitController({"interpolate_curvature_after_goal": True})
    with pytest.raises(ConfigError, match="did you mean 'lookahead_dist'"):
        RegulatedPurePursuitController({"lookahead_distance": 1.0})
    cls = CONTROLLERS.get("nav2_regulated_pure_pursuit_controller/"
                          "RegulatedPurePursuitController")
    assert cls is RegulatedPurePursuitController
    built = cls(cls.params_model.from_mapping({"desired_linear_vel": 0.3},
                                              key_path="FollowPath"))
    assert isinstance(built, RegulatedPurePursuitController)
    assert built.params.desired_linear_vel == 0.3


# A footprint reaching far behind the centre (as the Waffle Pi's) beside obstacles its
# rear corners sweep into: the old check projected (0, w) for 1 s, so its verdict changed
# with the odometry's w -- the controller alternated "turn" and "collision" and the robot
# crept round against the wall instead of failing (office explore_lite seed 4, 1355 s).
_LONG_TAIL = Footprint.from_polygon([[-0.4, -0.15], [-0.4, 0.15], [0.1, 0.15], [0.1, -0.15]])


def _with_obstacles(*polar: tuple[float, float], x0: float = 0.0) -> Costmap2D:
    """Lethal cells at ``(r, phi)`` around ``(x0, 0)``."""
    cm = _costmap()
    for r, phi in polar:
        cell = cm.world_to_map(x0 + r * math.cos(phi), r * math.sin(phi))
        assert cell is not None
        cm.data[cell[1], cell[0]] = 254
    return cm


@pytest.mark.parametrize("odom_w", [0.0, -0.2, -0.6, 0.2])
def test_turn_in_place_goes_the_free_way_round(odom_w: float) -> None:
    # carrot 1.6 rad to the right; turning right swings the rear-left corner into the
    # obstacle at 2.5 rad after ~0.3 rad, the other way round (3.9 rad to turn) is free
    cm = _with_obstacles((0.41, 2.5))
    ctrl = RegulatedPurePursuitController(footprint=_LONG_TAIL)
    cmd = ctrl.compute(Pose2D(), Twist2D(0.0, 0.0, odom_w), _ray(-1.6), cm)
    assert ctrl.is_rotating_to_heading and ctrl.turn_sign == 1.0
    assert cmd.vx == 0.0 and cmd.wz == pytest.approx(odom_w + 3.2 / 20.0)  # accel-limited
    # without the obstacle it turns the shorter way, as Nav2
    free = RegulatedPurePursuitController(footprint=_LONG_TAIL)
    assert free.compute(Pose2D(), Twist2D(), _ray(-1.6), _costmap()).wz < 0.0
    assert free.turn_sign == -1.0


@pytest.mark.parametrize("odom_w", [0.0, -0.05, -0.2, 0.2])
def test_turn_in_place_blocked_both_ways_fails_on_every_cycle(odom_w: float) -> None:
    cm = _with_obstacles((0.41, 2.5), (0.41, -2.45))
    ctrl = RegulatedPurePursuitController(footprint=_LONG_TAIL)
    with pytest.raises(CollisionAhead, match=r"turning in place toward the path is blocked "
                                             r"both ways: the robot footprint at \(0\.00, "
                                             r"0\.00\) would reach lethal cost 254 after "
                                             r"turning 0\.\d\d of 0\.82 rad the shorter way "
                                             r"and after 0\.\d\d of 3\.90 rad the other way; "
                                             r"back away from the obstacle") as err:
        ctrl.compute(Pose2D(), Twist2D(0.0, 0.0, odom_w), _ray(-1.6), cm)
    assert err.value.cost == 254 and ctrl.turn_sign == 0.0


def test_turn_under_way_keeps_its_direction() -> None:
    # started the long way round (left); half way the carrot is "shorter" to the left
    # anyway, and before that the right stays blocked: no switching back and forth
    cm = _with_obstacles((0.41, 2.5))
    ctrl = RegulatedPurePursuitController(footprint=_LONG_TAIL)
    for heading in (0.0, 0.5, 1.0, 1.5, 2.0, 2.5):
        cmd = ctrl.compute(Pose2D(0.0, 0.0, heading), Twist2D(0.0, 0.0, 0.05),
                           _ray(-1.6), cm)
        assert cmd.wz > 0.0, heading


def test_turn_blocked_both_ways_backs_out_when_enabled() -> None:
    cm = _with_obstacles((0.41, 2.5), (0.41, -2.45))
    ctrl = RegulatedPurePursuitController({"back_out_speed": 0.1}, footprint=_LONG_TAIL)
    cmd = ctrl.compute(Pose2D(), Twist2D(), _ray(-1.6), cm)
    assert (cmd.vx, cmd.wz) == (-0.1, 0.0) and ctrl.is_backing_out
    # 0.3 m backed out (back_out_max_distance): the turn fails as without backing out
    moved = _with_obstacles((0.41, 2.5), (0.41, -2.45), x0=-0.2)  # the pin moves along
    cmd = ctrl.compute(Pose2D(-0.2, 0.0, 0.0), Twist2D(-0.1), _ray(-1.6), moved)
    assert (cmd.vx, cmd.wz) == (-0.1, 0.0)
    moved = _with_obstacles((0.41, 2.5), (0.41, -2.45), x0=-0.3)
    with pytest.raises(CollisionAhead, match=r"blocked both ways: .* and backing out is "
                                             r"blocked or already 0\.30 m long; back away"):
        ctrl.compute(Pose2D(-0.3, 0.0, 0.0), Twist2D(-0.1), _ray(-1.6), moved)
    # a wall right behind: no backing out either
    behind = _with_obstacles((0.41, 2.5), (0.41, -2.45), (0.45, math.pi))
    ctrl = RegulatedPurePursuitController({"back_out_speed": 0.1}, footprint=_LONG_TAIL)
    with pytest.raises(CollisionAhead, match="backing out is blocked"):
        ctrl.compute(Pose2D(), Twist2D(), _ray(-1.6), behind)
    # one way free again after backing out: it turns, and may back out again next time
    free = RegulatedPurePursuitController({"back_out_speed": 0.1}, footprint=_LONG_TAIL)
    assert free.compute(Pose2D(), Twist2D(), _ray(-1.6), _costmap()).wz < 0.0
    assert not free.is_backing_out

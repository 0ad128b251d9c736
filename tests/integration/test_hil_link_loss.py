"""Acceptance 3 of the vehicle links, in the simulator through the real links: muting or
killing the simulated vehicle mid-run makes the driver command zero and report "link
lost" within 0.5 s, navigation pauses with that reason, and when the link returns the
same goal continues to success without a restart."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from navstack.core.msgs import DiagnosticStatus, Pose2D, PoseStamped
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.demo import demo_setup
from navstack.interfaces.hil import VehicleLink, hil_stack
from navstack.interfaces.stack import NavStack


def _run_until(stack: NavStack, nav: Navigator, t_end: float) -> None:
    while stack.now < t_end and not nav.isTaskComplete():
        stack.run_for(0.05)


def _link_loss_run(robot: str, goal: Pose2D, cut: Callable[[VehicleLink], None],
                   restore: Callable[[VehicleLink], None], t_cut: float, outage: float
                   ) -> None:
    setup = demo_setup(robot)
    stack, link = hil_stack(setup.world, robot, setup.nav2_params, seed=3)
    try:
        stack.start()
        driver = link.driver
        assert driver is not None
        written: list[tuple[float, bytes]] = []
        driver.command_listeners.append(lambda packet, _w: written.append((stack.now, packet)))
        statuses: list[tuple[float, DiagnosticStatus]] = []
        stack.runtime.bus.subscribe("/vehicle/status", DiagnosticStatus,
                                    lambda m: statuses.append((stack.now, m)))
        nav = Navigator(stack)
        assert nav.goToPose(PoseStamped.from_pose2d(goal, "map"))
        handle = stack.navigator.active_goal
        _run_until(stack, nav, t_cut)
        assert not nav.isTaskComplete()
        moving_before = abs(stack.sim.sim.state.vx)
        assert moving_before > 0.2, "the robot should be driving when the link is cut"
        cut(link)
        t0 = stack.now
        _run_until(stack, nav, t0 + 0.5)
        # the driver noticed within 0.5 s, reported it, and asked navigation to hold
        assert driver.watchdog.lost and driver.watchdog.lost_at is not None
        assert driver.watchdog.lost_at - t0 <= 0.5
        lost_status = [m for t, m in statuses if m.level == DiagnosticStatus.ERROR]
        assert lost_status and lost_status[0].message.startswith("link lost")
        assert lost_status[0].value("link_lost") == "true"
        _run_until(stack, nav, t0 + 1.0)
        assert stack.navigator.paused_reason.startswith("link lost"), \
            stack.navigator.paused_reason
        assert nav.getFeedback().paused_reason.startswith("link lost")
        # everything written since the loss is the stop command (if the link took it)
        after = [p for t, p in written if t > driver.watchdog.lost_at]
        assert all(driver.protocol.decode_command(p) == (0.0, 0.0) for p in after)
        assert driver.stops_sent >= len(after)
        _run_until(stack, nav, t0 + outage)
        assert abs(stack.sim.sim.state.vx) < 0.05, "the vehicle stopped on its own watchdog"
        assert not nav.isTaskComplete()
        restore(link)
        t1 = stack.now
        while driver.watchdog.lost and stack.now < t1 + 5.0:
            stack.run_for(0.05)
        assert not driver.watchdog.lost, "the link came back"
        stack.run_for(0.2)
        assert stack.navigator.paused_reason == ""
        assert stack.navigator.active_goal is handle, "same goal, no restart"
        _run_until(stack, nav, t1 + 120.0)
        assert nav.getResult() == TaskResult.SUCCEEDED, nav.getTaskResult()
        sim = stack.sim.sim
        assert sim.collisions == 0, (sim.pose, [o.pose_in(t) for o, t in zip(
            stack.world.moving_obstacles, sim.obstacle_clocks, strict=True)])
        assert driver.watchdog.losses == 1
        assert stack.sim.sim.pose.distance_to(goal) < 0.6
    finally:
        link.close()


def test_rover_udp_vehicle_muted_mid_run() -> None:
    _link_loss_run("rover", Pose2D(44.5, 27.0, 1.5708),
                   cut=lambda link: link.far_side.mute(),
                   restore=lambda link: link.far_side.unmute(), t_cut=8.0, outage=3.0)


@pytest.mark.parametrize("how", ["killed"])
def test_golf_cart_serial_vehicle_killed_mid_run(how: str) -> None:
    """The cart's Arduinos power off (their ptys close: the driver's ports report EIO)
    and come back on new ptys behind the same device names; the driver reconnects."""
    _link_loss_run("golf_cart", Pose2D(7.0, 50.0, 1.5708),
                   cut=lambda link: link.far_side.kill(),
                   restore=_restart, t_cut=12.0, outage=4.0)


def _restart(link: VehicleLink) -> None:
    link.far_side.restart()
    assert link.wait_connected(5.0), "the driver reconnects to the new ptys"

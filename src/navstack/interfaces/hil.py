"""Hardware-in-the-loop without hardware: the stack drives the simulator *through* a
vehicle's real wire protocol.

:class:`VehicleLink` is a :class:`~navstack.interfaces.stack.StackExtension`: given to
``NavStack(..., extensions=[link])`` it adds, when the stack starts,

* the simulated vehicle on the far side (:mod:`navstack.sim.vehicles`) -- the rover's
  VCU on a UDP socket on loopback, or the golf cart's two Arduinos on pty pairs -- with
  the robot's base, odometry and IMU/GNSS wired to it instead of to the bus;
* the :class:`~navstack.nodes.vehicle_driver.VehicleDriverNode` talking to it over the
  real link, exactly as ``navstack drive`` would to the real vehicle (only the
  addresses differ);
* the :class:`~navstack.sim.vehicles.bridge.HilBridgeNode` that keeps the two in lock
  step with the simulated clock and supplies the perfect ``map -> odom``.

So ``/cmd_vel`` goes encode -> socket/pty -> decode -> firmware -> robot, and the
odometry comes back the same way.  Use it with ``localization="external"`` (the bridge
publishes ``map -> odom``) -- :func:`hil_stack` does both.  ``vehicle_link.far_side``
has ``mute()``, ``kill()`` and ``restart()`` for link-loss tests.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np

from navstack.core.errors import ConfigError
from navstack.drivers.config import VehicleConfig, vehicle_from_mapping
from navstack.nodes.vehicle_driver import VehicleDriverNode
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import RobotParams, load_robot
from navstack.sim.vehicles.bridge import HilBridgeNode, HilVehicle
from navstack.sim.vehicles.far_side import FarSide
from navstack.sim.vehicles.vehicles import CartHil, RoverHil

__all__ = ["HIL_LINKS", "LinkKind", "VehicleLink", "hil_stack"]

LinkKind = Literal["udp", "serial"]
HIL_LINKS: dict[str, LinkKind] = {"rover": "udp", "golf_cart": "serial"}
"""The link each field robot's vehicle speaks (the robot profile name -> link kind)."""

# a plausible MPU9250 calibration (scale/cross-axis A, offsets b): the simulated Mega
# reads the distorted values, the driver undoes them
CART_ACCEL_A = ((1.012, 0.004, -0.003), (0.002, 0.991, 0.006), (-0.004, 0.001, 1.007))
CART_ACCEL_B = (0.12, -0.08, 0.21)
CART_MAG_A = ((1.08, 0.03, 0.0), (0.03, 0.95, 0.01), (0.0, 0.01, 1.02))
CART_MAG_B = (12.5, -7.0, 3.2)


class VehicleLink:
    """A simulated vehicle behind a real link, and the driver that talks to it."""

    def __init__(self, robot: str | RobotParams, link: LinkKind | None = None, *,
                 driver_overrides: dict[str, Any] | None = None,
                 sync_timeout: float = 1.0) -> None:
        self.robot = load_robot(robot) if isinstance(robot, str) else robot
        expected = HIL_LINKS.get(self.robot.name)
        if expected is None:
            raise ConfigError(f"no simulated vehicle for robot '{self.robot.name}'; vehicle "
                              f"links exist for {', '.join(sorted(HIL_LINKS))}",
                              key_path="robot")
        self.kind: LinkKind = link or expected
        if self.kind != expected:
            raise ConfigError(f"the {self.robot.name} talks to its vehicle over {expected}, not "
                              f"{self.kind}; use --link {expected}", key_path="link")
        self.driver_overrides = driver_overrides or {}
        self.sync_timeout = sync_timeout
        self._tmp: Path | None = None
        self.vehicle: HilVehicle = self._make_vehicle()
        self.wired = self.vehicle.wired
        self.driver: VehicleDriverNode | None = None
        self.bridge: HilBridgeNode | None = None

    @property
    def far_side(self) -> FarSide:
        return self.vehicle.far_side

    def _make_vehicle(self) -> HilVehicle:
        if self.kind == "udp":
            return RoverHil(self.robot, track_width=self.robot.kinematics.wheel_separation)
        self._tmp = Path(tempfile.mkdtemp(prefix="navstack-hil-"))
        return CartHil(self.robot, self._tmp,
                       (np.array(CART_ACCEL_A), np.array(CART_ACCEL_B)),
                       (np.array(CART_MAG_A), np.array(CART_MAG_B)))

    def vehicle_config(self) -> VehicleConfig:
        """The driver's vehicle YAML, pointing at the simulated vehicle's links."""
        common: dict[str, Any] = {
            "command": {"rate_hz": 20.0, "timeout": 0.5},
            "watchdog": {"timeout": 0.3, "restore_count": 3},
            "poll_rate_hz": 50.0}
        if isinstance(self.vehicle, RoverHil):
            host, port = self.vehicle.transport.local_address
            data: dict[str, Any] = {
                "type": "rover_vcu", "name": "rover (simulated VCU)",
                "links": {"vcu": {"type": "udp", "bind": "127.0.0.1:0",
                                  "remote": f"{host}:{port}"}},
                "geometry": {"track_width": self.robot.kinematics.wheel_separation,
                             "wheel_radius": 0.15}}
        else:
            assert isinstance(self.vehicle, CartHil)
            k = self.robot.kinematics
            data = {
                "type": "golf_cart", "name": "golf cart (simulated Arduinos)",
                "links": {"steering": {"type": "serial", "port": str(self.vehicle.steering_path),
                                       "baudrate": 115200, "reconnect_initial": 0.05,
                                       "reconnect_max": 0.2},
                          "sensors": {"type": "serial", "port": str(self.vehicle.sensors_path),
                                      "baudrate": 115200, "reconnect_initial": 0.05,
                                      "reconnect_max": 0.2}},
                "geometry": {"wheel_base": k.wheelbase, "wheel_separation": k.wheel_separation},
                "imu_calibration": {"accel": {"A": CART_ACCEL_A, "b": CART_ACCEL_B},
                                    "mag": {"A": CART_MAG_A, "b": CART_MAG_B}}}
        return vehicle_from_mapping(_merge({**data, **common}, self.driver_overrides),
                                    file="<hardware-in-the-loop>")

    def attach(self, runtime: Runtime, sim: SimulatorNode) -> None:
        """Start the vehicle, then add the driver and the bridge to ``runtime``."""
        far = self.vehicle.far_side
        far.start()
        driver = VehicleDriverNode(runtime, self.vehicle_config())
        if isinstance(self.vehicle, RoverHil):
            vcu = driver.transports["vcu"]
            vcu.open()  # binds now, so the vehicle knows where to send
            self.vehicle.transport.remote = vcu.local_address  # type: ignore[attr-defined]
        bridge = HilBridgeNode(runtime, sim, self.vehicle,
                               delivered=lambda link: driver.packets_queued.get(link, 0),
                               deliver=driver.poll, sync_timeout=self.sync_timeout)
        driver.command_listeners.append(bridge.on_command_written)
        self.driver, self.bridge = driver, bridge

    def ready(self, runtime: Runtime) -> bool:
        """Up once the driver's odometry and the bridge's ``map -> odom`` are in TF."""
        return runtime.tf.can_transform("map", "base_link")

    def wait_connected(self, timeout: float = 5.0) -> bool:
        """Block (wall time) until every driver link is open again -- after
        ``far_side.restart()``, so a test resumes at a reproducible simulated time."""
        deadline = time.monotonic() + timeout
        while self.driver is not None and not all(
                t.is_open for t in self.driver.transports.values()):
            if time.monotonic() > deadline:
                return False
            time.sleep(0.005)
        return True

    def close(self) -> None:
        """Stop the vehicle and the driver's links; remove the ptys."""
        self.vehicle.far_side.kill()
        if self.driver is not None:
            self.driver.on_shutdown()
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    def report(self) -> dict[str, Any]:
        """Link figures for a run report: latency, packets, malformed, sync timeouts."""
        out: dict[str, Any] = {"kind": self.kind, "vehicle": self.vehicle.name}
        if self.bridge is not None:
            out["command_latency"] = {k: round(v, 4) for k, v in
                                      self.bridge.latency_summary().items()}
            out["sync_timeouts"] = self.bridge.sync_timeouts
        if self.driver is not None:
            out["links"] = {n: {k: v for k, v in s.items()
                                if k in ("packets_rx", "packets_tx", "malformed", "io_errors",
                                         "reconnects")}
                            for n, s in self.driver.link_stats().items()}
            out["commands_sent"] = self.driver.commands_sent
            out["link_losses"] = self.driver.watchdog.losses
        return out


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def hil_stack(world: str, robot: str, nav2_params: str | Path | Mapping[str, Any] | None,
              seed: int,
              link: LinkKind | None = None, **stack_kwargs: Any) -> tuple[Any, VehicleLink]:
    """A NavStack whose robot is driven through its vehicle link (not started)."""
    from navstack.interfaces.stack import NavStack

    vehicle_link = VehicleLink(robot, link)
    stack = NavStack(world, vehicle_link.robot, nav2_params=nav2_params, seed=seed,
                     localization="external", extensions=[vehicle_link], **stack_kwargs)
    return stack, vehicle_link

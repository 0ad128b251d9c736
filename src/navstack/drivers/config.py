"""The vehicle YAML: which protocol, which links, and how the driver behaves.

``navstack drive --vehicle vehicle.yaml`` reads one of these (examples in
``docs/drivers.md``)::

    type: rover_vcu                 # rover_vcu | golf_cart
    name: rover
    links:
      vcu: {type: udp, bind: "0.0.0.0:5005", remote: "192.168.1.50:5006"}
    command: {rate_hz: 20, timeout: 0.5, compat: false, mode: auto}
    watchdog: {timeout: 0.3, restore_count: 3}
    geometry: {track_width: 0.8}

    type: golf_cart
    links:
      steering: {type: serial, port: /dev/ttyACM0, baudrate: 115200}
      sensors:  {type: serial, port: /dev/ttyACM1, baudrate: 115200}
      gnss:     {type: serial, port: /dev/ttyACM2, baudrate: 38400, protocol: nmea}
    command: {rate_hz: 20, steering_mode: physical}
    geometry: {wheel_base: 2.4, wheel_separation: 1.0}
    imu_calibration: {accel: {A: [[1,0,0],[0,1,0],[0,0,1]], b: [0,0,0]}}

Every key is validated: unknown keys, wrong types, a UDP link without ``bind``, a
serial link without ``port``, or a link the vehicle type needs but the file lacks are
:class:`~navstack.core.errors.ConfigError` naming the file and key path.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from pydantic import ConfigDict, Field, field_validator, model_validator

from navstack.core.config_files import load_yaml
from navstack.core.errors import ConfigError
from navstack.core.params import Params

__all__ = ["REQUIRED_LINKS", "AffineCalibration", "CommandParams", "FrameParams",
           "GeometryParams", "ImuCalibration", "LinkParams", "VehicleConfig",
           "WatchdogParams", "load_vehicle"]

VehicleType = Literal["rover_vcu", "golf_cart"]
REQUIRED_LINKS: dict[str, tuple[str, ...]] = {"rover_vcu": ("vcu",),
                                              "golf_cart": ("steering", "sensors")}
OPTIONAL_LINKS: dict[str, tuple[str, ...]] = {"rover_vcu": ("gnss",), "golf_cart": ("gnss",)}
_FINITE = ConfigDict(allow_inf_nan=False)
_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


class LinkParams(Params):
    """One link: UDP (``bind`` "ip:port", ``remote`` "ip:port") or serial (``port``,
    ``baudrate``); ``protocol`` for a GNSS link (nmea, ubx or auto)."""

    model_config = _FINITE

    type: Literal["udp", "serial"]
    bind: str | None = None
    remote: str | None = None
    port: str | None = None
    baudrate: int = Field(default=115200, gt=0)
    protocol: Literal["nmea", "ubx", "auto"] = "auto"
    reconnect_initial: float = Field(default=0.1, gt=0.0)
    reconnect_max: float = Field(default=2.0, gt=0.0)

    @model_validator(mode="after")
    def _complete(self) -> LinkParams:
        if self.type == "udp" and not self.bind:
            raise ValueError("a udp link needs bind: 'ip:port' (the address to listen on)")
        if self.type == "serial" and not self.port:
            raise ValueError("a serial link needs port: (e.g. /dev/ttyACM0)")
        return self


class CommandParams(Params):
    """How ``/cmd_vel`` becomes packets.

    ``rate_hz``: the latest command is sent at this fixed rate (and at once when a new
    ``/cmd_vel`` arrives); ``timeout``: a command older than this is replaced by zero
    (twist_mux's 0.5 s); ``compat``: the rover VCU's original arithmetic; ``mode``: the
    rover's LED mode; ``steering_mode``: the cart's steering formula."""

    model_config = _FINITE

    topic: str = "/cmd_vel"
    rate_hz: float = Field(default=20.0, gt=0.0, le=1000.0)
    send_on_update: bool = True
    timeout: float = Field(default=0.5, gt=0.0)
    compat: bool = False
    mode: Literal["teleop", "auto", "success"] = "auto"
    steering_mode: Literal["physical", "compat"] = "physical"


class WatchdogParams(Params):
    model_config = _FINITE

    timeout: float = Field(default=0.3, gt=0.0)
    restore_count: int = Field(default=3, ge=1)
    hold_topic: str = "/navigation/hold"
    """Where the driver asks navigation to pause while the link is lost."""


class GeometryParams(Params):
    """Cart: ``wheel_base`` / ``wheel_separation`` for the steering conversion; rover:
    ``track_width`` and ``wheel_radius`` (joint states)."""

    model_config = _FINITE

    wheel_base: float = Field(default=2.4, gt=0.0)
    wheel_separation: float = Field(default=1.0, ge=0.0)
    track_width: float = Field(default=0.8, gt=0.0)
    wheel_radius: float = Field(default=0.225, gt=0.0)


class FrameParams(Params):
    odom_frame: str = "odom"
    base_frame: str = "base_link"
    imu_frame: str = "imu_link"
    gps_frame: str = "gps_link"
    publish_tf: bool = True


class AffineCalibration(Params):
    """``calibrated = A (raw - b)``."""

    model_config = _FINITE

    A: tuple[tuple[float, float, float], tuple[float, float, float],
             tuple[float, float, float]] = _IDENTITY
    b: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def is_identity(self) -> bool:
        return self.A == _IDENTITY and self.b == (0.0, 0.0, 0.0)


class ImuCalibration(Params):
    accel: AffineCalibration = Field(default_factory=AffineCalibration)
    mag: AffineCalibration = Field(default_factory=AffineCalibration)


class VehicleConfig(Params):
    """A vehicle YAML (module docstring)."""

    type: VehicleType
    name: str = ""
    links: dict[str, LinkParams]
    command: CommandParams = Field(default_factory=CommandParams)
    watchdog: WatchdogParams = Field(default_factory=WatchdogParams)
    geometry: GeometryParams = Field(default_factory=GeometryParams)
    frames: FrameParams = Field(default_factory=FrameParams)
    imu_calibration: ImuCalibration = Field(default_factory=ImuCalibration)
    status_period: float = Field(default=1.0, gt=0.0)
    poll_rate_hz: float = Field(default=200.0, gt=0.0)

    @field_validator("links")
    @classmethod
    def _some(cls, value: dict[str, LinkParams]) -> dict[str, LinkParams]:
        if not value:
            raise ValueError("at least one link is needed")
        return value

    @model_validator(mode="after")
    def _links_for_type(self) -> VehicleConfig:
        need, may = REQUIRED_LINKS[self.type], OPTIONAL_LINKS[self.type]
        missing = [n for n in need if n not in self.links]
        unknown = [n for n in self.links if n not in need + may]
        if missing:
            raise ValueError(f"a {self.type} vehicle needs link(s) {', '.join(missing)} "
                             f"(links: {', '.join(need)}; optional: {', '.join(may)})")
        if unknown:
            raise ValueError(f"unknown link(s) {', '.join(unknown)} for a {self.type} vehicle "
                             f"(links: {', '.join(need + may)})")
        return self


def vehicle_from_mapping(data: Mapping[str, Any], *, file: str = "") -> VehicleConfig:
    return VehicleConfig.from_mapping(data, file=file, key_path="vehicle")


def load_vehicle(path: str | Path) -> VehicleConfig:
    """Read and validate a vehicle YAML; :class:`ConfigError` names the file and key."""
    data = load_yaml(Path(path))
    if not isinstance(data, Mapping):
        raise ConfigError("a vehicle file must be a mapping of keys", file=str(path))
    return vehicle_from_mapping(data, file=str(path))

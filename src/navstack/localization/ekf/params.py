"""robot_localization parameters for the EKF/UKF nodes, with its names and defaults.

Parameter files use robot_localization's ROS 2 layout and load unchanged::

    ekf_filter_node:
      ros__parameters:
        frequency: 30.0
        two_d_mode: true
        odom0: odom
        odom0_config: [false, false, false,  false, false, false,
                       true,  false, false,  false, false, true,
                       false, false, false]
        imu0: imu
        imu0_config: [...15 booleans...]

Sensors are numbered per type (``odom0``, ``odom1``, ``imu0``, ``pose0``, ``twist0`` ...);
each has a topic key and ``<sensor>_<option>`` keys (see ``SENSOR_OPTIONS``).  As in
robot_localization, ``process_noise_covariance`` and ``initial_estimate_covariance``
take 225 values (row-major 15 x 15) or 15 (the diagonal).  Reference: robot_localization
"State Estimation Nodes" documentation (docs.ros.org/en/rolling/p/robot_localization)
and Moore & Stouch 2014.

Every problem is a :class:`ConfigError` naming the file and the key, e.g.
``params.yaml: ekf_filter_node.odom0_config: must list 15 booleans (x, y, z, roll,
pitch, yaw, vx, vy, vz, vroll, vpitch, vyaw, ax, ay, az), got 14``.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, Self

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, ValidationError

from navstack.core.config_files import load_yaml, ros_parameters
from navstack.core.errors import ConfigError, ConfigErrors, did_you_mean
from navstack.core.params import Params, validation_to_config_error
from navstack.localization.ekf.model import (
    DEFAULT_INITIAL_ESTIMATE_DIAGONAL,
    DEFAULT_PROCESS_NOISE_DIAGONAL,
    STATE_SIZE,
)

__all__ = [
    "CONFIG_MESSAGE", "DBL_MAX", "EkfParams", "SensorKind", "SensorParams", "UkfParams",
    "load_filter_params",
]

DBL_MAX = sys.float_info.max
"""robot_localization's default rejection threshold (``numeric_limits<double>::max()``):
no gating."""

SensorKind = Literal["odom", "pose", "twist", "imu"]
SENSOR_KINDS: tuple[SensorKind, ...] = ("odom", "pose", "twist", "imu")

CONFIG_MESSAGE = ("must list 15 booleans (x, y, z, roll, pitch, yaw, vx, vy, vz, vroll, "
                  "vpitch, vyaw, ax, ay, az), got {n}")

_COMMON = ("config", "queue_size", "nodelay")
SENSOR_OPTIONS: dict[str, tuple[str, ...]] = {
    "odom": (*_COMMON, "differential", "relative", "pose_use_child_frame",
             "pose_rejection_threshold", "twist_rejection_threshold"),
    "pose": (*_COMMON, "differential", "relative", "pose_use_child_frame",
             "rejection_threshold"),
    "twist": (*_COMMON, "rejection_threshold"),
    "imu": (*_COMMON, "differential", "relative", "pose_rejection_threshold",
            "twist_rejection_threshold", "linear_acceleration_rejection_threshold",
            "remove_gravitational_acceleration"),
}
"""The ``<sensor>_<option>`` keys robot_localization reads for each sensor type."""

_SENSOR_KEY = re.compile(r"^(odom|pose|twist|imu)(\d+)(?:_(.+))?$")
_Threshold = Field(DBL_MAX, gt=0.0)


class SensorParams(Params):
    """One configured input (``odom0``, ``imu1`` ...): robot_localization's per-sensor keys.

    ``config`` is the 15-boolean update vector; ``differential`` turns consecutive poses
    into a velocity measurement; ``relative`` makes the first pose the origin;
    ``*_rejection_threshold`` gate on the Mahalanobis distance (in standard deviations);
    ``nodelay`` (TCP_NODELAY) is accepted and has no effect on the in-process bus.
    """

    name: str
    kind: SensorKind
    topic: str
    config: tuple[bool, ...] = (False,) * STATE_SIZE
    queue_size: int = Field(10, ge=1)
    nodelay: bool = False
    differential: bool = False
    relative: bool = False
    pose_use_child_frame: bool = False
    pose_rejection_threshold: float = _Threshold
    twist_rejection_threshold: float = _Threshold
    linear_acceleration_rejection_threshold: float = _Threshold
    remove_gravitational_acceleration: bool = False

    @property
    def update_vector(self) -> NDArray[np.bool_]:
        return np.array(self.config, dtype=bool)

    @property
    def use_differential(self) -> bool:
        """robot_localization: ``differential`` wins when both it and ``relative`` are set."""
        return self.differential

    @property
    def use_relative(self) -> bool:
        return self.relative and not self.differential


class EkfParams(Params):
    """``ekf_filter_node`` parameters (robot_localization names and ROS 2 defaults).

    ``sensor_timeout`` defaults to ``1 / frequency``; ``world_frame`` to ``odom_frame``;
    ``base_link_frame_output`` to ``base_link_frame``.  Control-term keys
    (``use_control`` ...) follow robot_localization's ``control_config`` semantics.
    ``debug`` / ``debug_out_file`` / ``use_sim_time`` are accepted for
    file compatibility (navstack logs through ``logging``; time is the runtime's clock).
    ``tf_prefix`` is prepended to the frame names (``robot1/odom``).
    ``transform_timeout``: in-process TF never has to wait for a transform; as upstream's
    ``lookupTransformSafe``, a lookup at the stamp falls back to the latest transform.
    """

    frequency: float = Field(30.0, gt=0.0)
    sensor_timeout: float | None = Field(None, gt=0.0)
    two_d_mode: bool = False
    transform_time_offset: float = 0.0
    transform_timeout: float = Field(0.0, ge=0.0)
    print_diagnostics: bool = False
    debug: bool = False
    debug_out_file: str = "robot_localization_debug.txt"
    permit_corrected_publication: bool = False
    publish_acceleration: bool = False
    publish_tf: bool = True
    map_frame: str = "map"
    odom_frame: str = "odom"
    base_link_frame: str = "base_link"
    base_link_frame_output: str | None = None
    world_frame: str | None = None
    tf_prefix: str = ""
    use_sim_time: bool = False
    predict_to_current_time: bool = False
    smooth_lagged_data: bool = False
    history_length: float = 0.0
    reset_on_time_jump: bool = False
    disabled_at_startup: bool = False
    gravitational_acceleration: float = Field(9.80665, gt=0.0)
    dynamic_process_noise_covariance: bool = False
    process_noise_covariance: tuple[float, ...] = DEFAULT_PROCESS_NOISE_DIAGONAL
    initial_estimate_covariance: tuple[float, ...] = DEFAULT_INITIAL_ESTIMATE_DIAGONAL
    initial_state: tuple[float, ...] | None = None
    use_control: bool = False
    stamped_control: bool = False
    control_timeout: float = Field(0.0, ge=0.0)
    control_config: tuple[bool, ...] = (False,) * 6
    acceleration_limits: tuple[float, ...] = (1.0,) * 6
    acceleration_gains: tuple[float, ...] = (1.0,) * 6
    deceleration_limits: tuple[float, ...] | None = None
    deceleration_gains: tuple[float, ...] | None = None
    sensors: tuple[SensorParams, ...] = ()

    # --- derived values ----------------------------------------------------------------
    @property
    def timeout(self) -> float:
        """Effective ``sensor_timeout`` [s]."""
        return self.sensor_timeout if self.sensor_timeout is not None else 1.0 / self.frequency

    @property
    def world(self) -> str:
        return self.world_frame or self.odom_frame

    @property
    def base_link_output(self) -> str:
        return self.base_link_frame_output or self.base_link_frame

    @property
    def process_noise(self) -> NDArray[np.float64]:
        return _square(self.process_noise_covariance)

    @property
    def initial_covariance(self) -> NDArray[np.float64]:
        return _square(self.initial_estimate_covariance)

    @property
    def decel_limits(self) -> tuple[float, ...]:
        return self.deceleration_limits or self.acceleration_limits

    @property
    def decel_gains(self) -> tuple[float, ...]:
        return self.deceleration_gains or self.acceleration_gains

    def sensor(self, name: str) -> SensorParams:
        for s in self.sensors:
            if s.name == name:
                return s
        raise KeyError(name)

    # --- loading -------------------------------------------------------------------------
    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Validate a ``ros__parameters`` mapping (sensor keys included)."""
        data = dict(data or {})
        if "sensors" in data:  # already-structured input (e.g. ``updated``)
            return super().from_mapping(data, file=file, key_path=key_path)
        sensors, rest = _split_sensor_keys(data, file, key_path)
        errors = _check_shapes(rest, file, key_path)
        if errors:
            raise errors[0] if len(errors) == 1 else ConfigErrors(errors)
        params = super().from_mapping({**rest, "sensors": sensors}, file=file,
                                      key_path=key_path)
        if params.tf_prefix:
            params = params.model_copy(update=params._prefixed_frames())
        params._check_frames(file, key_path)
        return params

    def _prefixed_frames(self) -> dict[str, str | None]:
        """Frames with ``tf_prefix/`` prepended (robot_localization ``appendPrefix``:
        leading slashes dropped)."""
        prefix = self.tf_prefix.lstrip("/")

        def add(frame: str | None) -> str | None:
            return None if frame is None else f"{prefix}/{frame.lstrip('/')}"

        return {"map_frame": add(self.map_frame), "odom_frame": add(self.odom_frame),
                "base_link_frame": add(self.base_link_frame),
                "base_link_frame_output": add(self.base_link_frame_output),
                "world_frame": add(self.world_frame)}

    def _check_frames(self, file: str, key_path: str) -> None:
        frames = {"map_frame": self.map_frame, "odom_frame": self.odom_frame,
                  "base_link_frame": self.base_link_frame}
        if len(set(frames.values())) != 3:
            raise ConfigError(f"map_frame, odom_frame and base_link_frame must differ (got "
                              f"{frames})", file=file, key_path=key_path or "frames")
        if self.world not in (self.map_frame, self.odom_frame):
            raise ConfigError(f"world_frame must be map_frame ('{self.map_frame}') or "
                              f"odom_frame ('{self.odom_frame}'), got '{self.world}'",
                              file=file, key_path=_join(key_path, "world_frame"))


class UkfParams(EkfParams):
    """``ukf_filter_node`` parameters: the EKF's plus the unscented transform's spread
    (robot_localization defaults ``alpha`` 0.001, ``kappa`` 0, ``beta`` 2)."""

    alpha: float = Field(0.001, gt=0.0, le=1.0)
    kappa: float = Field(0.0, gt=-STATE_SIZE)
    beta: float = Field(2.0, ge=0.0)


def load_filter_params(path: str | Path, node_name: str = "ekf_filter_node",
                       params_type: type[EkfParams] = EkfParams) -> EkfParams:
    """Read ``node_name``'s ``ros__parameters`` from a robot_localization YAML file."""
    data = load_yaml(path)
    section = ros_parameters(data, node_name, file=str(path), required=True)
    return params_type.from_mapping(section, file=str(path), key_path=node_name)


# --- helpers -------------------------------------------------------------------------------
def _join(prefix: str, key: str) -> str:
    return f"{prefix}.{key}" if prefix else key


def _square(values: tuple[float, ...]) -> NDArray[np.float64]:
    a = np.asarray(values, dtype=np.float64)
    return np.diag(a) if a.size == STATE_SIZE else a.reshape(STATE_SIZE, STATE_SIZE).copy()


def _check_shapes(rest: dict[str, Any], file: str, key_path: str) -> list[ConfigError]:
    """Array lengths robot_localization insists on, with messages that say which."""
    errors: list[ConfigError] = []
    for key in ("process_noise_covariance", "initial_estimate_covariance"):
        value = rest.get(key)
        if isinstance(value, list | tuple) and len(value) not in (STATE_SIZE,
                                                                   STATE_SIZE * STATE_SIZE):
            errors.append(ConfigError(
                f"must list {STATE_SIZE * STATE_SIZE} values (row-major 15 x 15) or "
                f"{STATE_SIZE} (the diagonal), got {len(value)}", file=file,
                key_path=_join(key_path, key)))
    value = rest.get("initial_state")
    if isinstance(value, list | tuple) and len(value) != STATE_SIZE:
        errors.append(ConfigError(f"must list {STATE_SIZE} values, got {len(value)}",
                                  file=file, key_path=_join(key_path, "initial_state")))
    for key in ("control_config", "acceleration_limits", "acceleration_gains",
                "deceleration_limits", "deceleration_gains"):
        value = rest.get(key)
        if isinstance(value, list | tuple) and len(value) != 6:
            errors.append(ConfigError(
                f"must list 6 values (vx, vy, vz, vroll, vpitch, vyaw), got {len(value)}",
                file=file, key_path=_join(key_path, key)))
    return errors


def _split_sensor_keys(data: dict[str, Any], file: str, key_path: str
                       ) -> tuple[list[SensorParams], dict[str, Any]]:
    """Group ``odom0``, ``odom0_config``, ... into validated :class:`SensorParams`."""
    groups: dict[tuple[str, int], dict[str, Any]] = {}
    rest: dict[str, Any] = {}
    for key, value in data.items():
        m = _SENSOR_KEY.match(str(key))
        if m is None:
            rest[key] = value
            continue
        kind, index, option = m.group(1), int(m.group(2)), m.group(3)
        groups.setdefault((kind, index), {})["topic" if option is None else option] = value
    errors: list[ConfigError] = []
    sensors: list[SensorParams] = []
    for kind in SENSOR_KINDS:
        indices = sorted(i for k, i in groups if k == kind)
        for expected, index in enumerate(indices):
            name = f"{kind}{index}"
            if index != expected:
                errors.append(ConfigError(
                    f"'{name}' is set but '{kind}{expected}' is not; robot_localization reads "
                    f"{kind}0, {kind}1, ... and stops at the first gap",
                    file=file, key_path=_join(key_path, name),
                    suggestion=f"renumber it '{kind}{expected}'"))
                continue
            group = groups[(kind, index)]
            try:
                sensors.append(_sensor(kind, name, group, file, key_path))
            except ConfigErrors as exc:
                errors.extend(exc.errors)
            except ConfigError as exc:
                errors.append(exc)
    if errors:
        raise errors[0] if len(errors) == 1 else ConfigErrors(errors)
    return sensors, rest


def _sensor(kind: SensorKind, name: str, group: dict[str, Any], file: str,
            key_path: str) -> SensorParams:
    allowed = SENSOR_OPTIONS[kind]
    errors: list[ConfigError] = []
    if "topic" not in group:
        errors.append(ConfigError(f"options for '{name}' are set but its topic is not",
                                  file=file, key_path=_join(key_path, name),
                                  suggestion=f"add '{name}: <topic>'"))
    elif not isinstance(group["topic"], str) or not group["topic"]:
        errors.append(ConfigError(f"must be a topic name (got {group['topic']!r})", file=file,
                                  key_path=_join(key_path, name)))
    for option in group:
        if option != "topic" and option not in allowed:
            hint = did_you_mean(f"{name}_{option}", [f"{name}_{o}" for o in allowed])
            errors.append(ConfigError(f"unknown key for {kind} input '{name}'", file=file,
                                      key_path=_join(key_path, f"{name}_{option}"),
                                      suggestion=hint.strip(" ()")))
    config = group.get("config")
    if config is not None and (not isinstance(config, list | tuple)
                               or len(config) != STATE_SIZE):
        n = len(config) if isinstance(config, list | tuple) else type(config).__name__
        errors.append(ConfigError(CONFIG_MESSAGE.format(n=n), file=file,
                                  key_path=_join(key_path, f"{name}_config")))
    elif config is not None and not all(isinstance(v, bool) for v in config):
        errors.append(ConfigError("must hold only true/false values", file=file,
                                  key_path=_join(key_path, f"{name}_config")))
    if errors:
        raise errors[0] if len(errors) == 1 else ConfigErrors(errors)
    values = dict(group)
    if kind in ("pose", "twist") and "rejection_threshold" in values:
        values["pose_rejection_threshold" if kind == "pose" else "twist_rejection_threshold"] \
            = values.pop("rejection_threshold")
    try:
        return SensorParams.model_validate({"name": name, "kind": kind, **values})
    except ValidationError as exc:
        err = validation_to_config_error(exc, SensorParams, file=file, key_path=key_path)
        # report the key as written in the file (odom0_queue_size, not queue_size)
        found = err.errors if isinstance(err, ConfigErrors) else [err]
        fixed = [ConfigError(e.reason, file=file,
                             key_path=_rename(e.key_path, key_path, name, kind),
                             suggestion=e.suggestion) for e in found]
        raise fixed[0] if len(fixed) == 1 else ConfigErrors(fixed) from None


def _rename(path: str, key_path: str, name: str, kind: str) -> str:
    prefix = f"{key_path}." if key_path else ""
    option = path[len(prefix):] if path.startswith(prefix) else path
    if option == "topic":
        return _join(key_path, name)
    if kind in ("pose", "twist") and option.endswith("_rejection_threshold"):
        option = "rejection_threshold"
    return _join(key_path, f"{name}_{option}")

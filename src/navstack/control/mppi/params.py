"""MPPI controller parameters in Nav2's ``nav2_mppi_controller`` layout.

Names and defaults are Nav2 Jazzy's (``Optimizer::getParams``, ``PathHandler::
initialize``, ``NoiseGenerator::initialize``, ``AckermannMotionModel``).  A critic's
section sits next to the controller keys under the critic's name and is validated by
that critic's own ``params_model`` (defined next to the critic, found through the
critic registry :data:`navstack.control.mppi.critics.CRITICS`); a Nav2 ``FollowPath``
section loads as is, nested (``GoalCritic: {cost_weight: 5.0}``) or with dotted keys
(``GoalCritic.cost_weight: 5.0``).  :meth:`MPPIParams.critic` returns a section.

Differences from Nav2, each because a navstack controller is a pure function of
``(pose, velocity, path, costmap)``:

* ``critics`` defaults to the list of Nav2's README configuration (Nav2's code default
  is an empty list, i.e. a controller that ignores path and obstacles);
* ``shift_control_sequence`` is a parameter (Nav2 derives it from the controller
  server's ``controller_frequency``).  Give ``controller_frequency`` to apply Nav2's rule:
  period equal to ``model_dt`` turns shifting on, shorter leaves it off, longer is an
  error;
* ``xy_goal_tolerance`` stands in for the goal checker Nav2 hands to the TwirlingCritic;
* ``seed`` seeds the noise generator so runs are reproducible;
* ``sgf_order`` (Savitzky-Golay order 1 or 2) is Nav2 Kilted's key.

Sign conventions follow Nav2: ``ax_max`` is used as ``|ax_max|`` and a positive
``ax_min``/``ay_min`` is negated (Nav2 warns and flips them).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal, Self

from pydantic import Field, SerializeAsAny, field_validator, model_validator

from navstack.control.mppi.critics import CRITICS, CriticParams
from navstack.core.errors import ConfigError, UnknownNameError, did_you_mean
from navstack.core.params import Params

DEFAULT_CRITICS: tuple[str, ...] = (
    "ConstraintCritic", "CostCritic", "GoalCritic", "GoalAngleCritic", "PathAlignCritic",
    "PathFollowCritic", "PathAngleCritic", "PreferForwardCritic",
)
"""The critic list of Nav2's README / nav2_params.yaml MPPI configuration."""

MotionModelName = Literal["DiffDrive", "Omni", "Ackermann"]


class AckermannConstraintsParams(Params):
    """``AckermannConstraints.min_turning_r`` [m] (Nav2 default 0.2)."""

    min_turning_r: float = Field(0.2, gt=0.0)


class TrajectoryVisualizerParams(Params):
    """Down-sampling of the published candidate trajectories (Nav2 keys)."""

    trajectory_step: int = Field(5, ge=1)
    time_step: int = Field(3, ge=1)


class MPPIParams(Params):
    """``nav2_mppi_controller::MPPIController`` parameters (one ``FollowPath`` section)."""

    plugin: str = "nav2_mppi_controller::MPPIController"
    motion_model: MotionModelName = "DiffDrive"
    critics: tuple[str, ...] = DEFAULT_CRITICS
    iteration_count: int = Field(1, ge=1)
    batch_size: int = Field(1000, ge=1)
    time_steps: int = Field(56, ge=2)
    model_dt: float = Field(0.05, gt=0.0)
    vx_std: float = Field(0.2, ge=0.0)
    vy_std: float = Field(0.2, ge=0.0)
    wz_std: float = Field(0.4, ge=0.0)
    vx_max: float = 0.5
    vx_min: float = -0.35
    vy_max: float = Field(0.5, ge=0.0)
    wz_max: float = Field(1.9, ge=0.0)
    ax_max: float = 3.0
    ax_min: float = -3.0
    ay_max: float = 3.0
    ay_min: float = -3.0
    az_max: float = Field(3.5, ge=0.0)
    temperature: float = Field(0.3, gt=0.0)
    gamma: float = Field(0.015, ge=0.0)
    visualize: bool = False
    retry_attempt_limit: int = Field(1, ge=0)
    regenerate_noises: bool = False
    open_loop: bool = False
    sgf_order: int = Field(2, ge=1, le=2)
    # path handler
    prune_distance: float = Field(1.5, gt=0.0)
    max_robot_pose_search_dist: float | None = Field(None, gt=0.0)
    transform_tolerance: float = Field(0.1, ge=0.0)
    enforce_path_inversion: bool = False
    inversion_xy_tolerance: float = Field(0.2, ge=0.0)
    inversion_yaw_tolerance: float = Field(0.4, ge=0.0)
    # navstack
    shift_control_sequence: bool = False
    controller_frequency: float | None = Field(None, gt=0.0)
    xy_goal_tolerance: float = Field(0.25, ge=0.0)
    seed: int = 0
    # sub-sections
    AckermannConstraints: AckermannConstraintsParams = Field(
        default_factory=AckermannConstraintsParams)
    TrajectoryVisualizer: TrajectoryVisualizerParams = Field(
        default_factory=TrajectoryVisualizerParams)
    critic_params: dict[str, SerializeAsAny[CriticParams]] = Field(default_factory=dict)
    """Validated critic sections by critic name: every listed critic's (defaults where the
    file gives none) and any other registered critic's section the file gives."""

    @field_validator("critics", mode="after")
    @classmethod
    def _known_critics(cls, names: tuple[str, ...]) -> tuple[str, ...]:
        canonical = tuple(_critic_name(name) for name in names)
        if len(set(canonical)) != len(canonical):
            raise ValueError(f"critics lists a critic twice: {list(names)}")
        return canonical

    @field_validator("critic_params", mode="before")
    @classmethod
    def _section_models(cls, sections: Any) -> Any:
        """Sections given as mappings (``model_dump`` round trips) become their critic's
        model; the keys become critic names."""
        if not isinstance(sections, Mapping):
            return sections
        out: dict[str, Any] = {}
        for key, section in sections.items():
            name = _critic_name(str(key))
            model = CRITICS.get(name).params_model
            out[name] = section if isinstance(section, model) else model.model_validate(
                section)
        return out

    @model_validator(mode="after")
    def _default_sections(self) -> Self:
        for name in self.critics:  # listed critics without a section use their defaults
            if name not in self.critic_params:
                self.critic_params[name] = CRITICS.get(name).params_model()
        return self

    @model_validator(mode="after")
    def _check_ranges(self) -> Self:
        if self.vx_min > self.vx_max:
            raise ValueError(f"vx_min ({self.vx_min}) must not exceed vx_max ({self.vx_max})")
        if self.controller_frequency is not None:
            period = 1.0 / self.controller_frequency
            if period > self.model_dt + 1e-6:
                raise ValueError(
                    f"controller period 1/controller_frequency = {period:.4f} s is longer "
                    f"than model_dt = {self.model_dt} s; set model_dt equal to the "
                    f"controller period (Nav2 refuses this too)")
        return self

    # --- derived values (Nav2 sign handling) ---------------------------------------------
    @property
    def accel_limits(self) -> tuple[float, float, float, float, float]:
        """``(ax_max, ax_min, ay_max, ay_min, az_max)`` with Nav2's sign corrections."""
        return (abs(self.ax_max), -abs(self.ax_min), abs(self.ay_max), -abs(self.ay_min),
                abs(self.az_max))

    @property
    def shifts_control_sequence(self) -> bool:
        """Whether the control sequence is shifted one step per cycle (Nav2 setOffset)."""
        if self.controller_frequency is not None:
            return abs(1.0 / self.controller_frequency - self.model_dt) < 1e-6
        return self.shift_control_sequence

    def critic(self, name: str) -> CriticParams:
        """The parameter section of critic ``name`` (its defaults if the file gave none).

        Typed as the base model; ``MyCritic.params_model`` is the concrete type.
        """
        canonical = _critic_name(name)
        section = self.critic_params.get(canonical)
        return section if section is not None else CRITICS.get(canonical).params_model()

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Validate a Nav2 ``FollowPath`` mapping; sub-section keys may be dotted.

        A mapping under a critic's name (or one listed in ``critics``) is that critic's
        section, validated by its ``params_model`` with errors naming
        ``<key_path>.<critic>.<key>``.
        """
        flat = dict(data or {})
        fields = cls.model_fields
        nested: dict[str, dict[str, Any]] = {}
        for key in list(flat):
            if "." in key:
                head, tail = key.split(".", 1)
                if head not in fields or head[0].isupper():
                    nested.setdefault(head, {})[tail] = flat.pop(key)
        for head, values in nested.items():
            current = flat.get(head, {})
            if not isinstance(current, Mapping):
                raise ConfigError(f"must be a mapping of parameters, got {current!r}",
                                  file=file, key_path=_join(key_path, head))
            flat[head] = {**dict(current), **values}
        sections = {str(k): v for k, v in dict(flat.pop("critic_params", {}) or {}).items()}
        for key in [k for k in flat if k not in fields]:
            if key in CRITICS:
                sections[key] = flat.pop(key)
            else:
                hint = did_you_mean(key, [*fields, *CRITICS.names()]).strip(" ()")
                raise ConfigError("unknown key", file=file, key_path=_join(key_path, key),
                                  suggestion=hint)
        validated: dict[str, CriticParams] = {}
        for key, section in sections.items():
            if not isinstance(section, Mapping):
                raise ConfigError(f"critic section must be a mapping of parameters, got "
                                  f"{section!r}", file=file, key_path=_join(key_path, key))
            model = CRITICS.get(key).params_model
            validated[CRITICS.canonical(key)] = model.from_mapping(
                section, file=file, key_path=_join(key_path, key))
        flat["critic_params"] = validated
        return super().from_mapping(flat, file=file, key_path=key_path)


def _critic_name(name: str) -> str:
    """The registered name of critic ``name`` (``mppi::critics::GoalCritic`` ->
    ``GoalCritic``); ValueError listing the known critics otherwise."""
    try:
        return CRITICS.canonical(name)
    except UnknownNameError:
        known = CRITICS.names()
        short = name.removeprefix("mppi::critics::")
        raise ValueError(f"unknown critic '{name}'{did_you_mean(short, known)}; known: "
                         f"{', '.join(known)}") from None


def _join(key_path: str, key: str) -> str:
    return f"{key_path}.{key}" if key_path else key

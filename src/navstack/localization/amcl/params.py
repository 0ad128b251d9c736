"""AMCL parameters with Nav2's ``nav2_amcl`` names and defaults.

Every field is a parameter of Nav2's ``amcl`` node (``amcl: ros__parameters:`` in a Nav2
parameter file), with the C++ default of ``nav2_amcl/src/amcl_node.cpp``; load a Nav2
file's section with ``AmclParams.from_mapping(ros_parameters(data, "amcl"), file=...)``
(:func:`navstack.core.config_files.ros_parameters`).

Where navstack interprets a value (Nav2 leaves it implicit):

* ``robot_model_type`` accepts Nav2's plugin names (``nav2_amcl::DifferentialMotionModel``,
  ``nav2_amcl::OmniMotionModel``) and the short names of older releases
  (``differential``, ``omnidirectional``/``omni``); the stored value is the plugin name.
* ``pf_z`` enters the KLD bound exactly as amcl uses it (as the ``z`` of the
  Wilson-Hilferty approximation, see :mod:`.particle_filter`).
* ``random_seed`` (Nav2 Kilted+): ``-1`` seeds from the operating system; any other value
  makes the filter reproducible.  A node given an explicit ``numpy.random.Generator``
  uses that instead.

navstack's own addition (not in Nav2; 0 keeps Nav2's behaviour):

* ``global_localization_anneal_updates``: after a global (uniform) initialisation the
  first N measurement updates use the likelihood raised to ``k / (N + 1)`` (k = 1..N),
  then the full likelihood.  With a sharp product likelihood the first update otherwise
  concentrates all particles on whichever look-alike place one particle happened to fit
  best, before any particle near the truth has been refined by the next scans; annealing
  (Neal, "Annealed importance sampling", 2001) keeps the competing hypotheses alive for
  those few updates.
"""

from __future__ import annotations

from typing import Literal, Self

from pydantic import Field, field_validator, model_validator

from navstack.core.params import Params

DIFFERENTIAL = "nav2_amcl::DifferentialMotionModel"
OMNI = "nav2_amcl::OmniMotionModel"
MOTION_MODEL_ALIASES: dict[str, str] = {
    DIFFERENTIAL: DIFFERENTIAL, "differential": DIFFERENTIAL, "diff": DIFFERENTIAL,
    OMNI: OMNI, "omnidirectional": OMNI, "omni": OMNI,
}
"""Accepted ``robot_model_type`` spellings -> the Nav2 plugin name."""

LaserModelType = Literal["likelihood_field", "beam", "likelihood_field_prob"]


class InitialPose(Params):
    """``initial_pose.{x,y,z,yaw}``: used when ``set_initial_pose`` is true [m, rad]."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0


class AmclParams(Params):
    """``nav2_amcl`` parameters (Nav2 names, Nav2 defaults).

    Motion noise ``alpha1..alpha5`` are the variance coefficients of the odometry motion
    model (Thrun, Burgard & Fox, *Probabilistic Robotics*, 2005, table 5.6); the laser
    mixture ``z_hit, z_short, z_max, z_rand, sigma_hit, lambda_short`` is the beam model
    of ch. 6.3 and the likelihood field of ch. 6.4; ``pf_err``/``pf_z`` bound the
    particle count by KLD-sampling (Fox, "Adapting the sample size in particle filters
    through KLD-sampling", IJRR 22(12), 2003); ``recovery_alpha_slow/fast`` are the
    ``alpha_slow/alpha_fast`` of Augmented_MCL (*Probabilistic Robotics* table 8.3).
    """

    use_sim_time: bool = False
    alpha1: float = Field(0.2, ge=0.0)
    alpha2: float = Field(0.2, ge=0.0)
    alpha3: float = Field(0.2, ge=0.0)
    alpha4: float = Field(0.2, ge=0.0)
    alpha5: float = Field(0.2, ge=0.0)
    base_frame_id: str = "base_footprint"
    beam_skip_distance: float = Field(0.5, ge=0.0)
    beam_skip_error_threshold: float = Field(0.9, ge=0.0, le=1.0)
    beam_skip_threshold: float = Field(0.3, ge=0.0, le=1.0)
    do_beamskip: bool = False
    global_frame_id: str = "map"
    lambda_short: float = Field(0.1, gt=0.0)
    laser_likelihood_max_dist: float = Field(2.0, gt=0.0)
    laser_max_range: float = 100.0
    laser_min_range: float = -1.0
    laser_model_type: LaserModelType = "likelihood_field"
    max_beams: int = Field(60, ge=2)
    max_particles: int = Field(2000, ge=1)
    min_particles: int = Field(500, ge=1)
    odom_frame_id: str = "odom"
    pf_err: float = Field(0.05, gt=0.0)
    pf_z: float = Field(0.99, gt=0.0)
    recovery_alpha_fast: float = Field(0.0, ge=0.0, le=1.0)
    recovery_alpha_slow: float = Field(0.0, ge=0.0, le=1.0)
    resample_interval: int = Field(1, ge=1)
    robot_model_type: str = DIFFERENTIAL
    save_pose_rate: float = 0.5
    sigma_hit: float = Field(0.2, gt=0.0)
    tf_broadcast: bool = True
    transform_tolerance: float = Field(1.0, ge=0.0)
    update_min_a: float = Field(0.2, ge=0.0)
    update_min_d: float = Field(0.25, ge=0.0)
    z_hit: float = Field(0.5, ge=0.0)
    z_max: float = Field(0.05, ge=0.0)
    z_rand: float = Field(0.5, ge=0.0)
    z_short: float = Field(0.05, ge=0.0)
    always_reset_initial_pose: bool = False
    scan_topic: str = "scan"
    map_topic: str = "map"
    set_initial_pose: bool = False
    initial_pose: InitialPose = InitialPose()
    first_map_only: bool = False
    freespace_downsampling: bool = False
    random_seed: int = -1
    global_localization_anneal_updates: int = Field(0, ge=0)

    @field_validator("robot_model_type")
    @classmethod
    def _known_motion_model(cls, value: str) -> str:
        try:
            return MOTION_MODEL_ALIASES[value]
        except KeyError:
            names = ", ".join(f"'{k}'" for k in MOTION_MODEL_ALIASES)
            raise ValueError(f"unknown motion model {value!r}; use one of {names}") from None

    @model_validator(mode="after")
    def _check_consistency(self) -> Self:
        if self.min_particles > self.max_particles:
            raise ValueError(f"min_particles ({self.min_particles}) must not exceed "
                             f"max_particles ({self.max_particles})")
        if self.z_hit + self.z_rand + self.z_short + self.z_max <= 0.0:
            raise ValueError("z_hit + z_short + z_max + z_rand must be positive "
                             "(the laser mixture weights; Nav2 uses 0.5, 0.05, 0.05, 0.5)")
        return self

    @property
    def omni(self) -> bool:
        """True for ``nav2_amcl::OmniMotionModel``."""
        return self.robot_model_type == OMNI

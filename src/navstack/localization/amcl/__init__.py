"""Adaptive Monte Carlo Localization with Nav2 ``nav2_amcl`` semantics.

The algorithm is pure (no bus, no clock): :class:`AmclFilter` = :class:`AmclMap` +
motion model (:mod:`.motion_model`) + laser model (:mod:`.sensor_model`) + the KLD-sampling
particle set (:mod:`.particle_filter`).  :class:`~navstack.nodes.amcl.AmclNode` in the node
layer is the runtime shell (``/scan``, ``/map``, ``/initialpose`` in; ``/amcl_pose``,
``/particle_cloud``, ``map -> odom`` out).

References: Thrun, Burgard & Fox, *Probabilistic Robotics*, MIT Press 2005 (ch. 4 particle
filters, ch. 5 motion models, ch. 6 measurement models, ch. 8 MCL/Augmented_MCL/KLD);
Fox, "Adapting the sample size in particle filters through KLD-sampling", IJRR 2003.
"""

from __future__ import annotations

from navstack.localization.amcl.motion_model import (
    DifferentialMotionModel,
    OmniMotionModel,
    make_motion_model,
    odometry_delta,
)
from navstack.localization.amcl.params import AmclParams, InitialPose
from navstack.localization.amcl.particle_filter import (
    AmclFilter,
    Cluster,
    InvalidInitialPose,
    ParticleFilter,
    kld_limit,
)
from navstack.localization.amcl.sensor_model import (
    AmclMap,
    AmclMapError,
    LaserData,
    LaserModel,
    prepare_scan,
)

__all__ = [
    "AmclFilter", "AmclMap", "AmclMapError", "AmclParams", "Cluster",
    "DifferentialMotionModel", "InitialPose", "InvalidInitialPose", "LaserData",
    "LaserModel", "OmniMotionModel", "ParticleFilter", "kld_limit", "make_motion_model",
    "odometry_delta", "prepare_scan",
]


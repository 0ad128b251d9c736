"""Adaptive Monte Carlo Localization with Nav2 ``nav2_amcl`` semantics.

The algorithm is pure (no bus, no clock): :class:`AmclFilter` = :class:`AmclMap` +
motion model (:mod:`.motion_model`) + laser model (:mod:`.sensor_model`) + the KLD-sampling
particle set (:mod:`.particle_filter`).  :class:`~navstack.localization.amcl.node.AmclNode`
is the runtime shell (``/scan``, ``/map``, ``/initialpose`` in; ``/amcl_pose``,
``/particle_cloud``, ``map -> odom`` out); it is imported lazily so that using the filter
alone never imports the runtime.

References: Thrun, Burgard & Fox, *Probabilistic Robotics*, MIT Press 2005 (ch. 4 particle
filters, ch. 5 motion models, ch. 6 measurement models, ch. 8 MCL/Augmented_MCL/KLD);
Fox, "Adapting the sample size in particle filters through KLD-sampling", IJRR 2003.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

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

if TYPE_CHECKING:
    from navstack.localization.amcl.node import AmclNode

__all__ = [
    "AmclFilter", "AmclMap", "AmclMapError", "AmclNode", "AmclParams", "Cluster",
    "DifferentialMotionModel", "InitialPose", "InvalidInitialPose", "LaserData",
    "LaserModel", "OmniMotionModel", "ParticleFilter", "kld_limit", "make_motion_model",
    "odometry_delta", "prepare_scan",
]


def __getattr__(name: str) -> Any:
    if name == "AmclNode":
        from navstack.localization.amcl.node import AmclNode

        return AmclNode
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

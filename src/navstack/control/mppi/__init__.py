"""Nav2's Model Predictive Path Integral controller (``nav2_mppi_controller``).

* :class:`MPPIController` — the controller (``compute(pose, velocity, path, costmap)``).
* :class:`MPPIParams` — parameters with Nav2's names, defaults and YAML layout.
* :func:`golf_cart_mppi_params` — a ready Ackermann configuration.

See ``docs/mppi.md`` for usage, parameters, differences from Nav2 and timings.
"""

from navstack.control.mppi.config import GOLF_CART_MPPI_YAML, golf_cart_mppi_params
from navstack.control.mppi.controller import MPPIController
from navstack.control.mppi.errors import MPPIInvalidPath, OptimizerFailed
from navstack.control.mppi.models import (
    AckermannMotionModel,
    DiffDriveMotionModel,
    MotionModel,
    OmniMotionModel,
)
from navstack.control.mppi.params import MPPIParams

__all__ = [
    "GOLF_CART_MPPI_YAML",
    "AckermannMotionModel",
    "DiffDriveMotionModel",
    "MPPIController",
    "MPPIInvalidPath",
    "MPPIParams",
    "MotionModel",
    "OmniMotionModel",
    "OptimizerFailed",
    "golf_cart_mppi_params",
]

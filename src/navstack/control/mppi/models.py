"""MPPI motion models (Nav2 ``mppi::DiffDriveMotionModel``, ``OmniMotionModel``,
``AckermannMotionModel``).

A motion model answers two questions for the optimizer:

* *how do sampled controls become velocities?*  ``MotionModel::predict``: every sampled
  control is clamped to what the previous velocity can reach in one ``model_dt`` under
  the acceleration limits (``ax_max``/``ax_min`` act on speed magnitude, so braking while
  reversing is limited like braking while driving forward; ``az_max`` is symmetric).
  This runs inside the rollout kernel (:mod:`navstack.control.mppi.rollout`);
  :attr:`MotionModel.is_holonomic` selects the variant there;
* *which hard limits does the optimal control sequence obey?*
  :meth:`MotionModel.apply_constraints`.  Only Ackermann has one: the turning-radius
  limit ``|wz| <= |vx| / min_turning_r`` (Nav2 ``AckermannMotionModel::applyConstraints``
  clamps ``wz`` into ``[-|vx|/r, |vx|/r]``).

Holonomic models (Omni) sample and integrate ``vy`` too.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from navstack.control.mppi.params import MPPIParams

FloatArray = NDArray[np.float64]

KIND_DIFF = 0
KIND_OMNI = 1
KIND_ACKERMANN = 2


class MotionModel:
    """Base motion model: non-holonomic, no extra constraints (DiffDrive behaviour)."""

    name: ClassVar[str] = "DiffDrive"
    kind: ClassVar[int] = KIND_DIFF
    is_holonomic: ClassVar[bool] = False

    @property
    def min_turning_r(self) -> float:
        """Minimum turning radius [m]; 0 means "turns in place"."""
        return 0.0

    def apply_constraints(self, vx: FloatArray, vy: FloatArray, wz: FloatArray) -> None:
        """Apply the model's hard limits to a control sequence in place (``(T,)`` each)."""


class DiffDriveMotionModel(MotionModel):
    """Differential drive: ``vx`` and ``wz``, turning in place allowed."""


class OmniMotionModel(MotionModel):
    """Omnidirectional: ``vx``, ``vy`` and ``wz``."""

    name: ClassVar[str] = "Omni"
    kind: ClassVar[int] = KIND_OMNI
    is_holonomic: ClassVar[bool] = True


class AckermannMotionModel(MotionModel):
    """Car-like: ``vx`` and ``wz`` with ``|wz| <= |vx| / min_turning_r``."""

    name: ClassVar[str] = "Ackermann"
    kind: ClassVar[int] = KIND_ACKERMANN

    def __init__(self, min_turning_r: float) -> None:
        if not min_turning_r > 0.0:
            raise ValueError(f"min_turning_r must be positive, got {min_turning_r}")
        self._min_turning_r = float(min_turning_r)

    @property
    def min_turning_r(self) -> float:
        return self._min_turning_r

    def apply_constraints(self, vx: FloatArray, vy: FloatArray, wz: FloatArray) -> None:
        limit = np.abs(vx) / self._min_turning_r
        np.clip(wz, -limit, limit, out=wz)


def make_motion_model(params: MPPIParams) -> MotionModel:
    """The motion model named by ``params.motion_model``."""
    if params.motion_model == "Omni":
        return OmniMotionModel()
    if params.motion_model == "Ackermann":
        return AckermannMotionModel(params.AckermannConstraints.min_turning_r)
    return DiffDriveMotionModel()

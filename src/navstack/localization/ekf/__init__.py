"""robot_localization's EKF and UKF state estimators (``navstack.localization.ekf``).

15-state omnidirectional model (Moore & Stouch, "A Generalized Extended Kalman Filter
Implementation for the Robot Operating System", 2014), robot_localization's parameter
names, defaults and YAML layout.  Pure filters (:class:`Ekf`, :class:`Ukf`) work on
:class:`Measurement` objects with no bus; :class:`EkfNode` is the ``ekf_filter_node`` /
``ukf_filter_node`` on the navstack runtime.
"""

from navstack.localization.ekf.ekf import CorrectionResult, Ekf, FilterBase, Measurement
from navstack.localization.ekf.measurements import (
    MeasurementBuilder,
    MeasurementRejected,
    SensorActivity,
)
from navstack.localization.ekf.model import STATE_NAMES, STATE_SIZE
from navstack.localization.ekf.node import EkfNode
from navstack.localization.ekf.params import (
    EkfParams,
    SensorParams,
    UkfParams,
    load_filter_params,
)
from navstack.localization.ekf.ukf import Ukf

__all__ = [
    "STATE_NAMES",
    "STATE_SIZE",
    "CorrectionResult",
    "Ekf",
    "EkfNode",
    "EkfParams",
    "FilterBase",
    "Measurement",
    "MeasurementBuilder",
    "MeasurementRejected",
    "SensorActivity",
    "SensorParams",
    "Ukf",
    "UkfParams",
    "load_filter_params",
]

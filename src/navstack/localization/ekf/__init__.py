"""robot_localization's EKF and UKF state estimators (``navstack.localization.ekf``).

15-state omnidirectional model (Moore & Stouch, "A Generalized Extended Kalman Filter
Implementation for the Robot Operating System", 2014), robot_localization's parameter
names, defaults and YAML layout.  Pure filters (:class:`Ekf`, :class:`Ukf`) work on
:class:`Measurement` objects with no bus; :class:`~navstack.nodes.ekf.EkfNode` is the
``ekf_filter_node`` / ``ukf_filter_node`` on the navstack runtime (the node layer).
"""

from navstack.localization.ekf.diagnostics import configuration_diagnostics
from navstack.localization.ekf.ekf import CorrectionResult, Ekf, FilterBase, Measurement
from navstack.localization.ekf.measurements import (
    MeasurementBuilder,
    MeasurementRejected,
    SensorActivity,
)
from navstack.localization.ekf.model import STATE_NAMES, STATE_SIZE
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
    "EkfParams",
    "FilterBase",
    "Measurement",
    "MeasurementBuilder",
    "MeasurementRejected",
    "SensorActivity",
    "SensorParams",
    "Ukf",
    "UkfParams",
    "configuration_diagnostics",
    "load_filter_params",
]

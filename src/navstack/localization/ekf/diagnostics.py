"""robot_localization's start-up check of a filter configuration (pure, no bus)."""

from __future__ import annotations

from collections import Counter

from navstack.localization.ekf.model import STATE_NAMES
from navstack.localization.ekf.params import EkfParams

__all__ = ["configuration_diagnostics"]


def configuration_diagnostics(params: EkfParams) -> list[str]:
    """robot_localization's start-up configuration warnings: several absolute sources of
    one pose variable (oscillation risk), or neither it nor its rate measured (unbounded
    error growth)."""
    absolute: Counter[int] = Counter()
    rates: Counter[int] = Counter()
    for s in params.sensors:
        u = s.config
        for i in range(6):
            if s.kind == "imu" and i < 3:  # sensor_msgs/Imu carries no position
                continue
            if s.kind in ("odom", "pose", "imu") and u[i] and not s.use_differential:
                absolute[i] += 1
            if (u[i] and s.use_differential) or (s.kind != "pose" and u[6 + i]):
                rates[i] += 1
    out = []
    for i in range(6):
        if params.two_d_mode and i in (2, 3, 4):
            continue
        if absolute[i] > 1:
            out.append(f"{absolute[i]} absolute pose inputs detected for {STATE_NAMES[i]}; "
                       "this may result in oscillations: make sure their variances are set "
                       "appropriately")
        elif absolute[i] == 0 and rates[i] == 0:
            out.append(f"neither {STATE_NAMES[i]} nor its velocity is measured: its error "
                       "will grow without bound")
    return out

"""Dead reckoning from wheel speed and yaw rate (the cart's ``heading += w dt;
x += v cos(heading) dt``), integrated exactly along the arc a constant (v, w) traces."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["DeadReckoning"]


@dataclass
class DeadReckoning:
    """Pose ``(x, y, yaw)`` in the odometry frame; :meth:`update` advances it."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    distance: float = 0.0

    def update(self, v: float, w: float, dt: float) -> None:
        """Hold the body speed ``v`` [m/s] and yaw rate ``w`` [rad/s] for ``dt`` [s]."""
        if not (dt > 0.0 and math.isfinite(v) and math.isfinite(w)):
            return
        h = 0.5 * w * dt
        k = dt if abs(h) < 1e-12 else dt * math.sin(h) / h
        mid = self.yaw + h
        self.x += v * k * math.cos(mid)
        self.y += v * k * math.sin(mid)
        self.yaw = math.atan2(math.sin(self.yaw + w * dt), math.cos(self.yaw + w * dt))
        self.distance += abs(v) * dt

"""Simulated GNSS receiver and magnetometer, placed on the Earth by a georeference.

Pure models like :mod:`navstack.sim.sensors`: every method takes the true state, ``now``
and the ``numpy.random.Generator`` explicitly.  The world frame is put on the Earth by
:class:`~navstack.sim.robot.GeoReferenceParams`: the world origin is the datum of a local
east-north-up frame (exact WGS84 ENU, :class:`navstack.geo.conversions.LocalCartesian`)
and the world x axis points at ENU yaw ``world_yaw``.

- :class:`GnssModel` -- sensor_msgs/NavSatFix of the antenna with white noise plus a
  first-order Gauss-Markov bias (the random walk-like wander of an uncorrected receiver,
  e.g. Farrell, "Aided Navigation", 2008, sec. 4.9), fix outages reported as
  ``STATUS_NO_FIX``, and the Doppler velocity in ENU (speed and course over ground) as
  geometry_msgs/TwistWithCovarianceStamped, like the ublox driver's ``fix_velocity``.
- :class:`MagnetometerModel` -- sensor_msgs/MagneticField of the Earth's field (declination,
  horizontal and vertical intensity) seen by a yawed sensor, with a heading offset,
  hard-iron offset and noise.
"""

from __future__ import annotations

import math

import numpy as np

from navstack.core.errors import InvalidMessage
from navstack.core.msgs import (
    Header,
    MagneticField,
    NavSatFix,
    NavSatStatus,
    Twist,
    TwistWithCovariance,
    TwistWithCovarianceStamped,
    Vector3,
)
from navstack.geo.conversions import LocalCartesian
from navstack.sim.kinematics import RobotState
from navstack.sim.robot import GeoReferenceParams, GnssParams, MagnetometerParams

__all__ = ["GnssModel", "MagnetometerModel", "world_to_enu"]

_MIN_VARIANCE = 1e-9
_SERVICE_GPS = 1
_UNKNOWN_COVARIANCE = 1e6


def world_to_enu(x: float, y: float, world_yaw: float) -> tuple[float, float]:
    """ENU (east, north) [m] of world point (x, y) for a world rotated by ``world_yaw``."""
    c, s = math.cos(world_yaw), math.sin(world_yaw)
    return c * x - s * y, s * x + c * y


class GnssModel:
    """A GNSS receiver whose antenna sits at ``params.mount`` on ``base_link``.

    Per axis (east, north) the reported position is the true antenna position plus a
    Gauss-Markov bias ``b_k = phi b_{k-1} + bias_std sqrt(1 - phi^2) w`` with
    ``phi = exp(-dt / bias_time_constant)`` (stationary std ``bias_std``; the first sample
    is drawn from the stationary distribution) plus white noise of
    ``horizontal_noise_std``.  The reported covariance (ENU, m^2, diagonal known) is the
    total variance ``horizontal_noise_std^2 + bias_std^2`` per horizontal axis.
    """

    def __init__(self, params: GnssParams, geo: GeoReferenceParams) -> None:
        self.params = params
        self.geo = geo
        self.rate_hz = params.rate_hz
        self.frame_id = params.frame_id
        self.enu = LocalCartesian(geo.latitude, geo.longitude, geo.altitude)
        p = params
        var_h = max(p.horizontal_noise_std ** 2 + p.bias_std ** 2, _MIN_VARIANCE)
        self._fix_cov = np.diag([var_h, var_h, max(p.vertical_noise_std ** 2, _MIN_VARIANCE)])
        var_v = max(p.velocity_noise_std ** 2, _MIN_VARIANCE)
        self._vel_cov = np.diag([var_v, var_v, var_v, _UNKNOWN_COVARIANCE,
                                 _UNKNOWN_COVARIANCE, _UNKNOWN_COVARIANCE])
        self.reset()

    def reset(self) -> None:
        """Forget the bias state (the next sample draws a fresh stationary bias)."""
        self.bias = (0.0, 0.0)
        self._last_t: float | None = None
        self.fixes = 0
        self.no_fixes = 0

    def in_outage(self, now: float) -> bool:
        """True while ``now`` lies in one of the configured ``[start, end)`` outages."""
        return any(start <= now < end for start, end in self.params.outages)

    def antenna_enu(self, state: RobotState) -> tuple[float, float, float]:
        """True ENU position [m] of the antenna about the datum."""
        m = self.params.mount
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        wx, wy = state.x + c * m.x - s * m.y, state.y + s * m.x + c * m.y
        e, n = world_to_enu(wx, wy, self.geo.world_yaw)
        return e, n, m.z

    def antenna_velocity_enu(self, state: RobotState) -> tuple[float, float]:
        """True ENU velocity [m/s] of the antenna (body velocity plus ``w x r``)."""
        m = self.params.mount
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        rx, ry = c * m.x - s * m.y, s * m.x + c * m.y
        vx = c * state.vx - s * state.vy - state.wz * ry
        vy = s * state.vx + c * state.vy + state.wz * rx
        return world_to_enu(vx, vy, self.geo.world_yaw)

    def _advance_bias(self, now: float, rng: np.random.Generator) -> None:
        p = self.params
        if p.bias_std <= 0.0:
            return
        if self._last_t is None:
            w = rng.standard_normal(2)
            self.bias = (p.bias_std * float(w[0]), p.bias_std * float(w[1]))
            return
        dt = max(now - self._last_t, 0.0)
        phi = math.exp(-dt / p.bias_time_constant)
        q = p.bias_std * math.sqrt(max(1.0 - phi * phi, 0.0))
        w = rng.standard_normal(2)
        self.bias = (phi * self.bias[0] + q * float(w[0]), phi * self.bias[1] + q * float(w[1]))

    def measure(self, state: RobotState, now: float, rng: np.random.Generator
                ) -> tuple[NavSatFix, TwistWithCovarianceStamped | None]:
        """The fix at ``now`` and the ENU velocity (``None`` during an outage)."""
        if not state.is_finite():
            raise InvalidMessage(f"gnss '{self.frame_id}' got a non-finite true state {state}")
        p = self.params
        header = Header(now, self.frame_id)
        self._advance_bias(now, rng)
        self._last_t = now
        if self.in_outage(now):
            self.no_fixes += 1
            fix = NavSatFix(header, NavSatStatus(NavSatStatus.STATUS_NO_FIX, _SERVICE_GPS),
                            math.nan, math.nan, math.nan, np.zeros((3, 3)),
                            NavSatFix.COVARIANCE_TYPE_UNKNOWN)
            return fix, None
        self.fixes += 1
        e, n, u = self.antenna_enu(state)
        noise = rng.standard_normal(5)
        e += self.bias[0] + p.horizontal_noise_std * float(noise[0])
        n += self.bias[1] + p.horizontal_noise_std * float(noise[1])
        u += p.vertical_noise_std * float(noise[2])
        lat, lon, alt = self.enu.reverse(e, n, u)
        fix = NavSatFix(header, NavSatStatus(NavSatStatus.STATUS_FIX, _SERVICE_GPS),
                        lat, lon, alt, self._fix_cov.copy(),
                        NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN)
        ve, vn = self.antenna_velocity_enu(state)
        ve += p.velocity_noise_std * float(noise[3])
        vn += p.velocity_noise_std * float(noise[4])
        vel = TwistWithCovarianceStamped(
            header, TwistWithCovariance(Twist(Vector3(ve, vn, 0.0)), self._vel_cov.copy()))
        return fix, vel


class MagnetometerModel:
    """A magnetometer at ``params.mount`` measuring the Earth's field in its own frame.

    The field in ENU is ``(H sin D, H cos D, -V)`` (``D`` the east-positive declination,
    ``H``/``V`` horizontal and downward vertical intensity).  The sensor's ENU yaw is the
    robot's world yaw plus ``world_yaw``, the mount yaw and ``heading_offset``; the field
    is rotated into that frame, then ``hard_iron`` and white noise are added.  The ENU yaw
    of the sensor follows from a reading as ``pi/2 - D - atan2(b_y, b_x)``.
    """

    def __init__(self, params: MagnetometerParams, geo: GeoReferenceParams) -> None:
        self.params = params
        self.geo = geo
        self.rate_hz = params.rate_hz
        self.frame_id = params.frame_id
        p = params
        self.field_enu = (p.horizontal_intensity * math.sin(p.declination),
                          p.horizontal_intensity * math.cos(p.declination),
                          -p.vertical_intensity)
        self._cov = np.diag([max(p.noise_std ** 2, _MIN_VARIANCE)] * 3)

    def sensor_yaw_enu(self, state: RobotState) -> float:
        """The yaw the sensor frame effectively has in ENU, offset included [rad]."""
        p = self.params
        return state.yaw + self.geo.world_yaw + p.mount.yaw + p.heading_offset

    def measure(self, state: RobotState, now: float,
                rng: np.random.Generator) -> MagneticField:
        if not state.is_finite():
            raise InvalidMessage(f"magnetometer '{self.frame_id}' got a non-finite true state")
        p = self.params
        psi = self.sensor_yaw_enu(state)
        c, s = math.cos(psi), math.sin(psi)
        fe, fn, fu = self.field_enu
        b = [c * fe + s * fn, -s * fe + c * fn, fu]
        if p.noise_std > 0.0:
            noise = rng.standard_normal(3)
            b = [b[i] + p.noise_std * float(noise[i]) for i in range(3)]
        hi = p.hard_iron
        return MagneticField(Header(now, self.frame_id),
                             Vector3(b[0] + hi[0], b[1] + hi[1], b[2] + hi[2]),
                             self._cov.copy())

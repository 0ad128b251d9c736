"""``Blacklist``: frontier cells explore_lite-style exploration must not pursue again.

explore_lite blacklists the *goal point* of a frontier whose navigation goal aborted or
made no progress, and skips frontiers whose centroid is within 5 cells of one.  A
centroid moves as the map grows, so a blacklisted frontier soon comes back under a new
centroid (and the robot returns to the spot it could not reach).  Here an entry keeps
the frontier's *cells* (world points), grown by ``tolerance``; frontier search removes
them before grouping, so only genuinely new frontier cells form frontiers.  Each entry
records why and how often it was tried; :meth:`Blacklist.release_retryable` lifts the
entries tried fewer than ``max_attempts`` times, so that exploration never ends while a
reachable frontier was abandoned only once (a person in the door, a transient failure).
A try that failed for a reason that is not the frontier's (the robot wedged on the way,
far from it) is recorded but not *blamed*: only blamed tries count toward
``max_attempts``, and ``2 * max_attempts`` tries in all end the retries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from navstack.exploration.grid_view import BoolArray, FloatArray, GridView
from navstack.exploration.wavefront import dilate

__all__ = ["Blacklist", "BlacklistEntry"]


@dataclass
class BlacklistEntry:
    """Blacklisted frontier: its cells' world points, why, when, how often tried."""

    points: FloatArray
    centroid: tuple[float, float]
    reason: str
    stamp: float
    attempts: int = 1
    active: bool = True
    blamed: int = 1
    """Tries that failed because of the frontier (``attempts`` counts every try)."""

    def describe(self) -> str:
        x, y = self.centroid
        return (f"frontier at ({x:.2f}, {y:.2f}) ({len(self.points)} cells, tried "
                f"{self.attempts}x): {self.reason}")


@dataclass
class Blacklist:
    """The blacklisted frontiers (module docstring)."""

    tolerance: float = 0.25
    max_attempts: int = 2
    entries: list[BlacklistEntry] = field(default_factory=list)

    def add(self, points: FloatArray, reason: str, stamp: float,
            blame: bool = True) -> BlacklistEntry:
        """Blacklist the frontier with cell centres ``points`` (N, 2); ``blame`` False:
        the try failed for a reason that is not the frontier's (module docstring)."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        before = [e for e in self.entries if _overlaps(e.points, pts, self.tolerance)]
        attempts = 1 + max((e.attempts for e in before), default=0)
        blamed = int(blame) + max((e.blamed for e in before), default=0)
        entry = BlacklistEntry(pts.copy(), (float(pts[:, 0].mean()), float(pts[:, 1].mean())),
                               reason, stamp, attempts, blamed=blamed)
        self.entries.append(entry)
        return entry

    @property
    def active(self) -> list[BlacklistEntry]:
        return [e for e in self.entries if e.active]

    def mask(self, view: GridView) -> BoolArray:
        """Cells of ``view`` covered by the active entries, grown by ``tolerance``."""
        out = np.zeros(view.shape, dtype=bool)
        active = self.active
        if not active:
            return out
        pts = np.concatenate([e.points for e in active])
        rows = np.floor((pts[:, 1] - view.origin_y) / view.resolution).astype(np.int64)
        cols = np.floor((pts[:, 0] - view.origin_x) / view.resolution).astype(np.int64)
        h, w = view.shape
        ok = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        out[rows[ok], cols[ok]] = True
        return dilate(out, math.ceil(self.tolerance / view.resolution - 1e-9))

    def release_retryable(self) -> list[BlacklistEntry]:
        """Lift the active entries blamed fewer than ``max_attempts`` times (and tried
        fewer than twice that); returns them."""
        released = [e for e in self.entries if e.active and e.blamed < self.max_attempts
                    and e.attempts < 2 * self.max_attempts]
        for e in released:
            e.active = False
        return released

    def describe(self) -> list[str]:
        return [e.describe() for e in self.active]


def _overlaps(a: FloatArray, b: FloatArray, tolerance: float) -> bool:
    """True when some point of ``a`` lies within ``tolerance`` of some point of ``b``."""
    if len(a) == 0 or len(b) == 0:
        return False
    lo = np.maximum(a.min(axis=0), b.min(axis=0)) - tolerance
    hi = np.minimum(a.max(axis=0), b.max(axis=0)) + tolerance
    if np.any(lo > hi):
        return False
    return bool(cKDTree(a).query(b, distance_upper_bound=tolerance + 1e-9)[0].min()
                <= tolerance + 1e-9)

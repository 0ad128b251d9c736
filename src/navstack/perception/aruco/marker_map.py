"""Markers on the map: repeated sightings fused into one pose per marker id.

Each sighting is a marker pose already transformed into the map frame (position, rotation,
3x3 position covariance, the IPPE ambiguity of the view, the camera distance).  Per id the
last ``window`` sightings are kept and the estimate is recomputed robustly on every new
one:

1. position: the component-wise median of the sightings is the reference; sightings
   whose Mahalanobis distance to it exceeds ``gate`` (covariance + ``position_floor``^2,
   the floor covering localisation and calibration errors the detector's covariance does
   not know) are outliers; the inliers are fused by their information (inverse
   covariance) -- the estimate's covariance is the fused one;
2. orientation: markers on the map stand on vertical surfaces (``upright``, the default:
   the estimate is the marker facing a horizontal direction), so only the facing yaw
   (the marker's z axis) is estimated, as the weighted circular median of the
   unambiguous views (IPPE ambiguity below ``max_ambiguity``; views where both IPPE
   solutions fit equally well flip the facing direction), refined by the circular mean
   of the views within ``yaw_gate`` of it.  With ``upright: false`` the rotation is the
   chordal mean (SVD projection of the summed matrices) of the inlier views.

An estimate is ``published`` once it has ``min_sightings`` position inliers.  The map
saves to and loads from YAML (:meth:`MarkerMap.save`, :meth:`MarkerMap.load`); a loaded
marker enters as one prior sighting with its saved covariance, which later sightings
refine.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.errors import ConfigError
from navstack.core.msgs import Quaternion
from navstack.core.params import Params
from navstack.core.rotations import matrix_to_quaternion, quaternion_to_matrix

FloatArray = NDArray[np.float64]


class MarkerMapParams(Params):
    """Fusion of marker sightings (navstack; see the module docstring)."""

    window: int = Field(default=60, ge=1)
    min_sightings: int = Field(default=3, ge=1)
    max_distance: float = Field(default=3.0, gt=0.0)
    """Sightings from farther than this [m] are ignored."""
    gate: float = Field(default=3.5, gt=0.0)
    position_floor: float = Field(default=0.03, ge=0.0)
    max_ambiguity: float = Field(default=0.6, gt=0.0, le=1.0)
    yaw_gate: float = Field(default=0.35, gt=0.0)
    upright: bool = True


@dataclass(frozen=True, eq=False)
class Sighting:
    """One marker pose in the map frame."""

    position: FloatArray
    rotation: FloatArray
    covariance: FloatArray
    stamp: float = 0.0
    ambiguity: float = 0.0
    distance: float = 0.0
    prior: bool = False

    @property
    def yaw(self) -> float:
        """Facing direction: yaw of the marker's z axis in the map."""
        return math.atan2(float(self.rotation[1, 2]), float(self.rotation[0, 2]))


@dataclass(frozen=True, eq=False)
class MarkerEstimate:
    """The fused pose of one marker in the map frame."""

    id: int
    position: FloatArray
    rotation: FloatArray
    covariance: FloatArray
    sightings: int
    inliers: int
    first_seen: float
    last_seen: float
    size: float = 0.0
    published: bool = False

    @property
    def yaw(self) -> float:
        return math.atan2(float(self.rotation[1, 2]), float(self.rotation[0, 2]))

    def matrix(self) -> FloatArray:
        """4x4 ``T_map_marker``."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.position
        return out


def upright_rotation(yaw: float) -> FloatArray:
    """Rotation of a marker on a vertical surface facing ``yaw`` (x right, y up, z out)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[-s, 0.0, c], [c, 0.0, s], [0.0, 1.0, 0.0]])


def _circular_median(angles: FloatArray, weights: FloatArray) -> float:
    """The angle minimising the weighted sum of absolute angular distances (checked at the
    samples)."""
    diff = np.abs(np.angle(np.exp(1j * (angles[:, None] - angles[None, :]))))
    return float(angles[int(np.argmin(diff @ weights))])


def _wrap(a: FloatArray | float) -> Any:
    return np.angle(np.exp(1j * np.asarray(a)))


@dataclass
class _Track:
    sightings: deque[Sighting]
    first_seen: float
    total: int = 0
    size: float = 0.0
    estimate: MarkerEstimate | None = None


@dataclass
class MarkerMap:
    """Fused marker poses by id (see module docstring)."""

    params: MarkerMapParams = field(default_factory=MarkerMapParams)
    frame_id: str = "map"
    _tracks: dict[int, _Track] = field(default_factory=dict)
    rejected_far: int = 0

    def ids(self) -> list[int]:
        return sorted(self._tracks)

    def estimate(self, marker_id: int) -> MarkerEstimate | None:
        track = self._tracks.get(marker_id)
        return track.estimate if track is not None else None

    def estimates(self, published_only: bool = True) -> list[MarkerEstimate]:
        out = [t.estimate for _, t in sorted(self._tracks.items()) if t.estimate is not None]
        return [e for e in out if e.published or not published_only]

    def add(self, marker_id: int, sighting: Sighting, size: float = 0.0) -> MarkerEstimate | None:
        """Fuse one sighting; returns the new estimate (``None`` if the sighting was too far
        to use)."""
        p = self.params
        if not sighting.prior and sighting.distance > p.max_distance:
            self.rejected_far += 1
            return self.estimate(marker_id)
        track = self._tracks.get(marker_id)
        if track is None:
            track = _Track(deque(maxlen=p.window), sighting.stamp)
            self._tracks[marker_id] = track
        if sighting.prior:
            prior = [s for s in track.sightings if s.prior]
            rest = [s for s in track.sightings if not s.prior]
            track.sightings = deque([*prior, sighting, *rest][-p.window:], maxlen=p.window)
        else:
            track.sightings.append(sighting)
        track.total += 1
        track.size = size or track.size
        track.estimate = self._fuse(marker_id, track)
        return track.estimate

    def _fuse(self, marker_id: int, track: _Track) -> MarkerEstimate:
        p = self.params
        ss = list(track.sightings)
        pos = np.array([s.position for s in ss])
        floor = p.position_floor ** 2 * np.eye(3)
        covs = np.array([s.covariance + floor for s in ss])
        infos = np.linalg.inv(covs)
        median = np.median(pos, axis=0)
        d = pos - median
        m2 = np.einsum("ni,nij,nj->n", d, infos, d)
        inl = m2 <= p.gate ** 2
        if inl.sum() < max(1, len(ss) // 3):  # no consensus around the median: keep closest
            inl = m2 <= np.partition(m2, len(ss) // 2)[len(ss) // 2]
        info = infos[inl].sum(axis=0)
        cov = np.linalg.inv(info)
        position = cov @ np.einsum("nij,nj->i", infos[inl], pos[inl])
        rotation = self._rotation([s for s, ok in zip(ss, inl, strict=True) if ok])
        n_inl = int(inl.sum())
        published = n_inl >= p.min_sightings or any(s.prior for s in ss)
        return MarkerEstimate(marker_id, position, rotation, cov, track.total, n_inl,
                              track.first_seen, max(s.stamp for s in ss), track.size, published)

    def _rotation(self, ss: list[Sighting]) -> FloatArray:
        p = self.params
        clear = [s for s in ss if s.prior or s.ambiguity < p.max_ambiguity] or ss
        if not p.upright:
            total = sum((s.rotation for s in clear), np.zeros((3, 3)))
            u, _, vt = np.linalg.svd(total)
            r = u @ vt
            if np.linalg.det(r) < 0.0:
                u[:, -1] = -u[:, -1]
                r = u @ vt
            return np.asarray(r)
        yaws = np.array([s.yaw for s in clear])
        weights = np.array([1.0 / max(s.distance, 0.3) for s in clear])
        centre = _circular_median(yaws, weights)
        near = np.abs(_wrap(yaws - centre)) <= p.yaw_gate
        mean = centre + float(np.angle(np.sum(weights[near] * np.exp(1j * _wrap(
            yaws[near] - centre)))))
        return upright_rotation(float(_wrap(mean)))

    # --- YAML ---------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        markers = []
        for e in self.estimates():
            q = matrix_to_quaternion(e.rotation)
            c = e.covariance
            markers.append({
                "id": int(e.id), "size": round(float(e.size), 6),
                "position": [round(float(v), 6) for v in e.position],
                "orientation": [round(float(v), 9) for v in (q.x, q.y, q.z, q.w)],
                "yaw": round(float(e.yaw), 6),
                "covariance": [float(f"{v:.6g}") for v in (c[0, 0], c[0, 1], c[0, 2], c[1, 1],
                                                          c[1, 2], c[2, 2])],
                "sightings": int(e.sightings)})
        return {"frame_id": self.frame_id, "markers": markers}

    def save(self, path: str | Path) -> Path:
        """Write the published markers as YAML (see :meth:`load` for the format)."""
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text("# navstack marker map: fused ArUco marker poses (marker frame: x right, "
                       "y up, z out of the marker)\n" + yaml.safe_dump(self.to_dict(),
                                                                       sort_keys=False))
        return out

    @staticmethod
    def load(path: str | Path, params: MarkerMapParams | None = None) -> MarkerMap:
        """A map from a YAML written by :meth:`save`: ``frame_id`` and ``markers``, each with
        ``id``, ``position`` [x, y, z], ``orientation`` [x, y, z, w] and optional ``size``,
        ``covariance`` (xx, xy, xz, yy, yz, zz) and ``sightings``."""
        src = Path(path)
        try:
            doc = yaml.safe_load(src.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ConfigError("marker map file not found", file=str(src)) from None
        except (OSError, yaml.YAMLError) as exc:
            raise ConfigError(f"cannot read marker map: {exc}", file=str(src)) from None
        if not isinstance(doc, dict) or not isinstance(doc.get("markers", []), list):
            raise ConfigError("a marker map is a mapping with a 'markers' list", file=str(src))
        out = MarkerMap(params or MarkerMapParams(), str(doc.get("frame_id", "map")))
        for i, m in enumerate(doc.get("markers") or []):
            key = f"markers[{i}]"
            try:
                marker_id = int(m["id"])
                position = np.array(m["position"], dtype=np.float64).reshape(3)
                q = [float(v) for v in m["orientation"]]
                if len(q) != 4:
                    raise ValueError("orientation needs 4 values")
                rotation = quaternion_to_matrix(Quaternion(*q))
                c = [float(v) for v in m.get("covariance", [1e-4, 0, 0, 1e-4, 0, 1e-4])]
                cov = np.array([[c[0], c[1], c[2]], [c[1], c[3], c[4]], [c[2], c[4], c[5]]])
            except (KeyError, TypeError, ValueError, IndexError) as exc:
                raise ConfigError(f"invalid marker entry ({exc})", file=str(src),
                                  key_path=key,
                                  suggestion="each marker needs id, position [x, y, z] and "
                                             "orientation [x, y, z, w]") from None
            if marker_id in out._tracks:
                raise ConfigError(f"marker {marker_id} appears twice", file=str(src),
                                  key_path=key)
            out.add(marker_id, Sighting(position, rotation, cov, prior=True),
                    float(m.get("size", 0.0)))
        return out


__all__ = ["MarkerEstimate", "MarkerMap", "MarkerMapParams", "Sighting", "upright_rotation"]

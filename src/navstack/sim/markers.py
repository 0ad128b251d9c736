"""Fiducial markers and marked packages in a simulated world.

A :class:`WorldMarker` is a square ArUco marker on a vertical surface: centre
``(x, y, z)`` [m], facing direction ``yaw`` (the marker's z axis, horizontal, pointing
away from the surface it is stuck on) and ``size`` (the side of the black square, the
length ArUco pose estimation needs).  Around it is a white quiet zone ``margin`` [m]
wide, as on printed markers.  The marker frame is OpenCV's: x to the right and y up as a
viewer facing the marker reads it, z towards the viewer.

A :class:`PackageSpec` is a small box lying on the floor (TurtleBot course: 10 x 5 x
5 cm) with a marker of its id on each vertical face it fits on.  Packages are lower than
the lidar plane: the lidar does not see them, the camera and the collision check do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Pose2D

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class WorldMarker:
    """A marker on a vertical surface (see module docstring); lengths in metres."""

    id: int
    dictionary: str
    size: float
    x: float
    y: float
    z: float
    yaw: float
    margin: float = 0.0
    package: int | None = None
    """Index of the package the marker is printed on (``None``: fixed in the world)."""

    @property
    def normal(self) -> FloatArray:
        """Unit z axis of the marker (facing direction) in the world."""
        return np.array([math.cos(self.yaw), math.sin(self.yaw), 0.0])

    def rotation(self) -> FloatArray:
        """``R_world_marker``: columns are the marker's x (right), y (up), z (normal)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[-s, 0.0, c], [c, 0.0, s], [0.0, 1.0, 0.0]])

    def corners(self, extra: float = 0.0) -> FloatArray:
        """World corners ``(4, 3)`` of the square of side ``size + 2 * extra`` in OpenCV's
        order: top-left, top-right, bottom-right, bottom-left."""
        h = 0.5 * self.size + extra
        local = np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])
        return local @ self.rotation().T + (self.x, self.y, self.z)

    def pose_matrix(self) -> FloatArray:
        """4x4 homogeneous ``T_world_marker``."""
        t = np.eye(4)
        t[:3, :3] = self.rotation()
        t[:3, 3] = (self.x, self.y, self.z)
        return t


@dataclass(frozen=True)
class PackageSpec:
    """A marked box on the floor: ``size`` = (length along its yaw, width, height) [m]."""

    name: str
    marker_id: int
    dictionary: str
    x: float
    y: float
    yaw: float = 0.0
    size: tuple[float, float, float] = (0.10, 0.05, 0.05)
    marker_size: float = 0.05

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    def polygon_at(self, pose: Pose2D) -> FloatArray:
        """Footprint corners ``(4, 2)`` at ``pose`` (counter-clockwise)."""
        hl, hw = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        return np.column_stack((pose.x + c * local[:, 0] - s * local[:, 1],
                                pose.y + s * local[:, 0] + c * local[:, 1]))

    def markers_at(self, pose: Pose2D, index: int, z: float = 0.0) -> list[WorldMarker]:
        """The package's markers at ``pose`` (box bottom at height ``z``): one centred on
        each vertical face at least ``marker_size`` wide and tall, facing outwards."""
        length, width, height = self.size
        out = []
        for half_extent, face_width, yaw_offset in ((0.5 * length, width, 0.0),
                                                    (0.5 * width, length, 0.5 * math.pi),
                                                    (0.5 * length, width, math.pi),
                                                    (0.5 * width, length, -0.5 * math.pi)):
            if face_width + 1e-9 < self.marker_size or height + 1e-9 < self.marker_size:
                continue
            yaw = pose.theta + yaw_offset
            # 1 mm proud of the face so the box's own face never hides it
            d = half_extent + 1e-3
            out.append(WorldMarker(self.marker_id, self.dictionary, self.marker_size,
                                   pose.x + d * math.cos(yaw), pose.y + d * math.sin(yaw),
                                   z + 0.5 * height, math.atan2(math.sin(yaw), math.cos(yaw)),
                                   0.0, index))
        return out


__all__ = ["PackageSpec", "WorldMarker"]

"""Simulated pinhole camera: grey images of a 2.5-D world with ArUco markers, or just the
markers' projected corners.

Geometry.  The camera is level (no roll or pitch) at the mount's height; square pixels,
``fx = fy = (width / 2) / tan(horizontal_fov / 2)``, principal point at the image centre
``((width - 1) / 2, (height - 1) / 2)`` with pixel centres at integer coordinates (the
OpenCV convention the detector uses).  The image is in the optical frame (z forward,
x right, y down).

Image mode, per frame:

1. background -- one lidar ray per image column (:func:`navstack.sim.raycast.cast_rays`
   against the grid and the moving obstacles) gives the distance to the wall seen in that
   column; every occupied cell is a wall ``world.wall_height`` tall, so the wall fills the
   rows between ``cy - fy (H - z) / d`` and ``cy + fy z / d``.  Walls are shaded by face
   orientation and distance (with a seam every metre so they are not featureless), the
   floor and ceiling by row;
2. packages (boxes on the floor), far to near, as anti-aliased polygons;
3. markers -- each visible marker's quad (with its white quiet zone) is found by
   projecting its corners; the OpenCV-generated marker image is warped onto it with
   ``warpPerspective`` at ``oversample`` times the resolution and area-averaged back
   down (anti-aliasing: without it the corners snap to the pixel grid and the pose
   error at 3 m roughly doubles).  A marker column is hidden where that column's ray
   hit a wall in front of the marker (occlusion per column, exact in a 2.5-D world);
4. optional motion blur (horizontal, the rotation during the exposure), lens distortion
   (plumb_bob, by remapping) and pixel noise (pre-drawn Gaussian table).

Corners mode reports each marker whose four corners are in the image, unoccluded,
within ``max_range`` and at least ``min_marker_pixels`` apart, with Gaussian corner noise:
what a detector would output, without rendering or detecting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from numpy.typing import NDArray

from navstack.core.aruco_dictionaries import get_dictionary
from navstack.core.msgs import Header, Pose2D
from navstack.core.msgs.camera_msgs import CameraInfo, Image
from navstack.core.msgs.fiducial_msgs import Fiducial, FiducialArray
from navstack.sim.camera_kernels import add_noise, fill_background, wall_rows
from navstack.sim.markers import PackageSpec, WorldMarker
from navstack.sim.raycast import cast_rays
from navstack.sim.robot import CameraParams
from navstack.sim.world import World

FloatArray = NDArray[np.float64]
NEAR = 0.05
"""Closest distance [m] at which a marker corner is drawn or reported."""
RANGE_LIMIT = 50.0
"""Furthest wall [m] the column rays look for."""
TEXTURE_CELL_PX = 24
"""Texture pixels per marker cell."""
WHITE, BLACK = 225, 25
"""Grey levels of a marker's white and black cells in full light."""
PACKAGE_GREY = (205, 180, 150)
"""Grey of a package's top face, the faces seen square-on and obliquely."""


@lru_cache(maxsize=256)
def marker_texture(dictionary: str, marker_id: int, margin_cells: float) -> NDArray[np.uint8]:
    """The marker image (black WHITE/BLACK cells) with ``margin_cells`` cells of white
    around it, ``TEXTURE_CELL_PX`` pixels per cell.  Cached (read-only)."""
    d = get_dictionary(dictionary)
    cells = int(d.markerSize) + 2
    side = cells * TEXTURE_CELL_PX
    core = cv2.aruco.generateImageMarker(d, int(marker_id), side, borderBits=1)
    pad = round(margin_cells * TEXTURE_CELL_PX)
    tex = cv2.copyMakeBorder(core, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
    out: NDArray[np.uint8] = np.where(tex > 127, WHITE, BLACK).astype(np.uint8)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class CameraPose:
    """Optical centre ``(x, y, z)`` in the world and heading ``yaw`` of the level camera."""

    x: float
    y: float
    z: float
    yaw: float


@dataclass(frozen=True)
class ProjectedMarker:
    """A marker in view: its corners ``(4, 2)`` [px, OpenCV order] and camera distance."""

    marker: WorldMarker
    corners: FloatArray
    distance: float


class CameraModel:
    """A level pinhole camera of :class:`CameraParams` (see module docstring)."""

    def __init__(self, params: CameraParams) -> None:
        self.params = params
        w, h = params.width, params.height
        self.width, self.height = w, h
        self.fx = self.fy = 0.5 * w / math.tan(0.5 * params.horizontal_fov)
        self.cx, self.cy = 0.5 * (w - 1), 0.5 * (h - 1)
        self.K = np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])
        self.D = np.asarray(params.distortion, dtype=np.float64)
        # column u looks along yaw + col_angles[u] (image x grows to the right = -y)
        self.col_angles: FloatArray = np.arctan(-(np.arange(w) - self.cx) / self.fx)
        self.col_cos: FloatArray = np.cos(self.col_angles)
        self._ranges = np.empty(w)
        self._base = self._floor_and_ceiling()
        self._maps = self._distortion_maps() if np.any(self.D != 0.0) else None
        self._noise = None
        if params.pixel_noise_std > 0.0:
            table = np.random.default_rng(12345).standard_normal(1 << 20) * params.pixel_noise_std
            self._noise = np.clip(np.rint(table), -255, 255).astype(np.int16)

    # --- calibration --------------------------------------------------------------------
    def camera_info(self, stamp: float = 0.0) -> CameraInfo:
        """sensor_msgs/CameraInfo of this camera (plumb_bob, no rectification)."""
        k = tuple(float(v) for v in self.K.reshape(-1))
        p = (self.fx, 0.0, self.cx, 0.0, 0.0, self.fy, self.cy, 0.0, 0.0, 0.0, 1.0, 0.0)
        return CameraInfo(Header(stamp, self.params.optical_frame), self.height, self.width,
                          "plumb_bob", tuple(float(v) for v in self.D), k,
                          (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), p)

    def pose_in_world(self, robot: Pose2D) -> CameraPose:
        """The camera's pose given the ``base_link`` pose."""
        m = self.params.mount
        c, s = math.cos(robot.theta), math.sin(robot.theta)
        return CameraPose(robot.x + c * m.x - s * m.y, robot.y + s * m.x + c * m.y, m.z,
                          robot.theta + m.yaw)

    @staticmethod
    def world_to_optical(cam: CameraPose) -> FloatArray:
        """4x4 ``T_optical_world`` (maps world points into the optical frame)."""
        c, s = math.cos(cam.yaw), math.sin(cam.yaw)
        # body (x fwd, y left, z up) -> optical (x right, y down, z fwd)
        r = np.array([[s, -c, 0.0], [0.0, 0.0, -1.0], [c, s, 0.0]])
        t = np.eye(4)
        t[:3, :3] = r
        t[:3, 3] = -r @ np.array([cam.x, cam.y, cam.z])
        return t

    def marker_in_optical(self, marker: WorldMarker, robot: Pose2D) -> FloatArray:
        """Ground truth 4x4 ``T_optical_marker`` of ``marker`` seen from ``robot``."""
        return self.world_to_optical(self.pose_in_world(robot)) @ marker.pose_matrix()

    def project(self, cam: CameraPose, points: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Pixels ``(N, 2)`` (distorted if the camera has distortion) and depths ``(N,)``
        of world points ``(N, 3)``."""
        t = self.world_to_optical(cam)
        p = points @ t[:3, :3].T + t[:3, 3]
        z = p[:, 2]
        safe = np.where(z > 1e-9, z, 1e-9)
        xn, yn = p[:, 0] / safe, p[:, 1] / safe
        if self._maps is not None:
            xn, yn = self._distort_normalised(xn, yn)
        return np.column_stack((self.fx * xn + self.cx, self.fy * yn + self.cy)), z

    def _distort_normalised(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
        k1, k2, p1, p2, k3 = self.D
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        return (x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y)

    # --- what is in view ----------------------------------------------------------------
    def all_markers(self, world: World, package_poses: list[Pose2D] | None = None
                    ) -> list[WorldMarker]:
        """The world's fixed markers plus those on the packages at ``package_poses``
        (default: where the world places them)."""
        out = list(world.markers)
        for i, pkg in enumerate(world.packages):
            pose = pkg.pose if package_poses is None else package_poses[i]
            out.extend(pkg.markers_at(pose, i))
        return out

    def column_ranges(self, world: World, cam: CameraPose, moving: tuple[FloatArray, FloatArray]
                      | None) -> FloatArray:
        """Distance [m] to the first wall along each image column (``inf``: none)."""
        circles, segments = moving if moving is not None else (None, None)
        return cast_rays(world.occupied, world.origin_x, world.origin_y, world.resolution,
                         cam.x, cam.y, cam.yaw, self.col_angles, 0.0, RANGE_LIMIT, circles,
                         segments, self._ranges)

    def _tolerance(self, world: World, cos_incidence: FloatArray) -> FloatArray:
        # a rasterised face lies up to half a cell from the true one, more along a slant ray
        return world.resolution * (0.5 + 0.5 / np.maximum(np.abs(cos_incidence), 0.25))

    def _column_visibility(self, world: World, cam: CameraPose, marker: WorldMarker,
                           cols: NDArray[np.int64], ranges: FloatArray) -> NDArray[np.bool_]:
        """Which image columns ``cols`` see ``marker``'s plane before any wall."""
        ang = cam.yaw + self.col_angles[cols]
        dx, dy = np.cos(ang), np.sin(ang)
        n = marker.normal
        denom = dx * n[0] + dy * n[1]
        num = (marker.x - cam.x) * n[0] + (marker.y - cam.y) * n[1]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(np.abs(denom) > 1e-9, num / denom, np.inf)
        return np.asarray(t <= ranges[cols] + self._tolerance(world, denom))

    def visible_markers(self, world: World, robot: Pose2D, moving: tuple[FloatArray, FloatArray]
                        | None = None, package_poses: list[Pose2D] | None = None,
                        ranges: FloatArray | None = None, extra: bool = False
                        ) -> list[ProjectedMarker]:
        """Markers facing the camera, in front of it, with some part inside the image;
        ``extra`` projects the outer edge of the quiet zone instead of the marker square.
        Partly occluded markers are included (the caller decides)."""
        cam = self.pose_in_world(robot)
        out = []
        for marker in self.all_markers(world, package_poses):
            to_cam = np.array([cam.x - marker.x, cam.y - marker.y, cam.z - marker.z])
            if float(to_cam @ marker.normal) <= 0.0:
                continue
            corners, depth = self.project(cam, marker.corners(marker.margin if extra else 0.0))
            if np.any(depth < NEAR):
                continue
            if (corners[:, 0].max() < 0 or corners[:, 0].min() > self.width - 1
                    or corners[:, 1].max() < 0 or corners[:, 1].min() > self.height - 1):
                continue
            out.append(ProjectedMarker(marker, corners, float(np.linalg.norm(to_cam))))
        return out

    # --- corners mode -------------------------------------------------------------------
    def detect_corners(self, world: World, robot: Pose2D, rng: np.random.Generator,
                       moving: tuple[FloatArray, FloatArray] | None = None,
                       package_poses: list[Pose2D] | None = None) -> list[tuple[int, FloatArray]]:
        """``(id, corners (4, 2))`` of every marker a detector would find (module
        docstring), corners with ``corner_noise_std`` pixel noise."""
        p = self.params
        cam = self.pose_in_world(robot)
        found = []
        ranges: FloatArray | None = None
        for pm in self.visible_markers(world, robot, moving, package_poses):
            c = pm.corners
            if pm.distance > p.max_range:
                continue
            if (c[:, 0].min() < 0 or c[:, 0].max() > self.width - 1 or c[:, 1].min() < 0
                    or c[:, 1].max() > self.height - 1):
                continue
            sides = np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1)
            if sides.min() < p.min_marker_pixels:
                continue
            if ranges is None:
                ranges = self.column_ranges(world, cam, moving).copy()
            cols = np.clip(np.rint(c[:, 0]).astype(np.int64), 0, self.width - 1)
            if not self._column_visibility(world, cam, pm.marker, cols, ranges).all():
                continue
            if p.corner_noise_std > 0.0:
                c = c + rng.normal(0.0, p.corner_noise_std, c.shape)
            found.append((pm.marker.id, c))
        return found

    def fiducials(self, world: World, robot: Pose2D, rng: np.random.Generator, stamp: float,
                  moving: tuple[FloatArray, FloatArray] | None = None,
                  package_poses: list[Pose2D] | None = None, seq: int = 0) -> FiducialArray:
        """Corners mode as a fiducial_msgs/FiducialArray in the optical frame."""
        found = self.detect_corners(world, robot, rng, moving, package_poses)
        return FiducialArray(Header(stamp, self.params.optical_frame), seq,
                             tuple(Fiducial.from_corners(i, c) for i, c in found))

    # --- image mode ---------------------------------------------------------------------
    def render(self, world: World, robot: Pose2D, rng: np.random.Generator,
               moving: tuple[FloatArray, FloatArray] | None = None,
               package_poses: list[Pose2D] | None = None, yaw_rate: float = 0.0
               ) -> NDArray[np.uint8]:
        """One grey frame ``(height, width)`` uint8 (module docstring)."""
        p = self.params
        cam = self.pose_in_world(robot)
        ranges = self.column_ranges(world, cam, moving)
        top, bottom, depth = wall_rows(ranges, self.col_cos, self.fy, self.cy, cam.z,
                                       world.wall_height, self.height)
        img = np.empty((self.height, self.width), dtype=np.uint8)
        fill_background(img, self._base, top, bottom, self._wall_shade(world, cam, ranges,
                                                                       depth))
        if world.packages:
            poses = package_poses or [pkg.pose for pkg in world.packages]
            order = sorted(range(len(poses)), key=lambda i: -math.hypot(poses[i].x - cam.x,
                                                                        poses[i].y - cam.y))
            for i in order:
                self._draw_package(img, world, cam, world.packages[i], poses[i], ranges)
                for marker in world.packages[i].markers_at(poses[i], i):
                    self._draw_marker(img, world, cam, marker, ranges)
        for marker in world.markers:
            self._draw_marker(img, world, cam, marker, ranges)
        if p.motion_blur and p.exposure_time > 0.0:
            length = round(abs(yaw_rate) * p.exposure_time * self.fx)
            if length >= 2:
                img = np.asarray(cv2.blur(img, (length, 1)), dtype=np.uint8)
        if self._maps is not None:
            img = np.asarray(cv2.remap(img, self._maps[0], self._maps[1], cv2.INTER_LINEAR,
                                       borderMode=cv2.BORDER_REPLICATE), dtype=np.uint8)
        if self._noise is not None:
            add_noise(img, self._noise, int(rng.integers(0, self._noise.shape[0])))
        return img

    def image(self, world: World, robot: Pose2D, rng: np.random.Generator, stamp: float,
              moving: tuple[FloatArray, FloatArray] | None = None,
              package_poses: list[Pose2D] | None = None, yaw_rate: float = 0.0) -> Image:
        """:meth:`render` as a sensor_msgs/Image (``encoding`` of the params)."""
        grey = self.render(world, robot, rng, moving, package_poses, yaw_rate)
        img = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR) if self.params.encoding == "bgr8" else grey
        return Image.from_array(img, self.params.encoding,
                                Header(stamp, self.params.optical_frame))

    def _floor_and_ceiling(self) -> NDArray[np.uint8]:
        rows = np.arange(self.height, dtype=np.float64) - self.cy
        z = max(self.params.mount.z, 0.02)
        with np.errstate(divide="ignore"):
            floor_dist = np.where(rows > 0.0, self.fy * z / np.maximum(rows, 1e-9), np.inf)
        floor = 120.0 + 45.0 * np.exp(-floor_dist / 3.0)
        ceiling = 200.0 - 20.0 * np.exp(rows / (0.5 * self.height))
        col = np.where(rows > 0.0, floor, ceiling)
        return np.ascontiguousarray(np.repeat(col[:, None], self.width, axis=1)
                                    .clip(0, 255).astype(np.uint8))

    def _wall_shade(self, world: World, cam: CameraPose, ranges: FloatArray,
                    depth: FloatArray) -> NDArray[np.uint8]:
        ang = cam.yaw + self.col_angles
        finite = np.isfinite(ranges)
        r = np.where(finite, ranges, 0.0)
        hx, hy = cam.x + r * np.cos(ang), cam.y + r * np.sin(ang)
        fx = (hx - world.origin_x) / world.resolution
        fy = (hy - world.origin_y) / world.resolution
        # the face hit: x-faces where the hit lies on a vertical cell border
        on_x = np.abs(fx - np.rint(fx)) < np.abs(fy - np.rint(fy))
        along = np.where(on_x, hy, hx)
        seam = np.abs(along - np.rint(along)) < 0.01
        shade = 175.0 * np.where(on_x, 1.0, 0.82) * (0.6 + 0.4 * np.exp(-depth / 6.0))
        shade = np.where(seam, 0.85 * shade, shade)
        return np.where(finite, shade, 0.0).clip(0, 255).astype(np.uint8)

    def _distortion_maps(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """For every distorted pixel, where the pinhole image has it."""
        u, v = np.meshgrid(np.arange(self.width, dtype=np.float64),
                           np.arange(self.height, dtype=np.float64))
        pts = np.column_stack((u.ravel(), v.ravel())).reshape(-1, 1, 2)
        und = cv2.undistortPoints(pts, self.K, self.D, P=self.K).reshape(self.height,
                                                                         self.width, 2)
        return und[..., 0].astype(np.float32), und[..., 1].astype(np.float32)

    def _patch_bounds(self, pts: FloatArray) -> tuple[int, int, int, int] | None:
        x0 = max(math.floor(pts[:, 0].min()) - 1, 0)
        x1 = min(math.ceil(pts[:, 0].max()) + 2, self.width)
        y0 = max(math.floor(pts[:, 1].min()) - 1, 0)
        y1 = min(math.ceil(pts[:, 1].max()) + 2, self.height)
        if x1 - x0 < 1 or y1 - y0 < 1:
            return None
        return x0, x1, y0, y1

    def _oversample(self, bw: int, bh: int) -> int:
        k = self.params.oversample
        while k > 1 and bw * bh * k * k > 2_000_000:
            k -= 1
        return k

    def _pinhole(self, cam: CameraPose, points: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Undistorted pixels (the render is distorted as a whole afterwards)."""
        t = self.world_to_optical(cam)
        q = points @ t[:3, :3].T + t[:3, 3]
        z = q[:, 2]
        safe = np.where(z > 1e-9, z, 1e-9)
        return np.column_stack((self.fx * q[:, 0] / safe + self.cx,
                                self.fy * q[:, 1] / safe + self.cy)), z

    def _draw_marker(self, img: NDArray[np.uint8], world: World, cam: CameraPose,
                     marker: WorldMarker, ranges: FloatArray) -> None:
        to_cam = np.array([cam.x - marker.x, cam.y - marker.y, cam.z - marker.z])
        dist = float(np.linalg.norm(to_cam))
        cos_view = float(to_cam @ marker.normal) / max(dist, 1e-9)
        if cos_view <= 0.02:
            return
        quad, depth = self._pinhole(cam, marker.corners(marker.margin))
        if np.any(depth < NEAR):
            return
        bounds = self._patch_bounds(quad)
        if bounds is None:
            return
        x0, x1, y0, y1 = bounds
        bw, bh = x1 - x0, y1 - y0
        k = self._oversample(bw, bh)
        cells = marker.size / (get_dictionary(marker.dictionary).markerSize + 2)
        tex = marker_texture(marker.dictionary, marker.id, marker.margin / cells)
        light = 0.75 + 0.25 * cos_view
        if light < 0.999:
            tex = np.asarray(cv2.convertScaleAbs(tex, alpha=light), dtype=np.uint8)
        side = tex.shape[0]
        src = np.array([[-0.5, -0.5], [side - 0.5, -0.5], [side - 0.5, side - 0.5],
                        [-0.5, side - 0.5]], dtype=np.float32)
        dst = (k * (quad - (x0, y0)) + 0.5 * (k - 1)).astype(np.float32)
        region = img[y0:y1, x0:x1]
        big = (cv2.resize(region, (bw * k, bh * k), interpolation=cv2.INTER_NEAREST)
               if k > 1 else region.copy())
        h = cv2.getPerspectiveTransform(src, dst)
        cv2.warpPerspective(tex, h, (bw * k, bh * k), dst=big,
                            flags=cv2.INTER_NEAREST if k >= 3 else cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_TRANSPARENT)
        small = cv2.resize(big, (bw, bh), interpolation=cv2.INTER_AREA) if k > 1 else big
        cols = np.arange(x0, x1)
        visible = self._column_visibility(world, cam, marker, cols, ranges)
        if visible.all():
            region[:] = small
        elif visible.any():
            region[:, visible] = small[:, visible]

    def _draw_package(self, img: NDArray[np.uint8], world: World, cam: CameraPose,
                      package: PackageSpec, pose: Pose2D, ranges: FloatArray) -> None:
        footprint = package.polygon_at(pose)
        height = package.size[2]
        centre = footprint.mean(axis=0)
        if math.hypot(centre[0] - cam.x, centre[1] - cam.y) > RANGE_LIMIT:
            return
        bottom = np.column_stack((footprint, np.zeros(4)))
        top = np.column_stack((footprint, np.full(4, height)))
        faces = []
        for i in range(4):
            j = (i + 1) % 4
            edge = footprint[j] - footprint[i]
            normal = np.array([edge[1], -edge[0]]) / max(float(np.hypot(*edge)), 1e-9)
            mid = 0.5 * (footprint[i] + footprint[j])
            view = np.array([cam.x, cam.y]) - mid
            cos_view = float(view @ normal) / max(float(np.hypot(*view)), 1e-9)
            if cos_view > 0.0:
                grey = PACKAGE_GREY[2] + (PACKAGE_GREY[1] - PACKAGE_GREY[2]) * cos_view
                faces.append((np.array([top[i], top[j], bottom[j], bottom[i]]), grey))
        if cam.z > height:
            faces.append((top, float(PACKAGE_GREY[0])))
        pts_all = []
        for poly, _ in faces:
            px, depth = self._pinhole(cam, poly)
            if np.any(depth < NEAR):
                return
            pts_all.append(px)
        if not pts_all:
            return
        bounds = self._patch_bounds(np.vstack(pts_all))
        if bounds is None:
            return
        x0, x1, y0, y1 = bounds
        region = img[y0:y1, x0:x1]
        patch = region.copy()
        for (_, grey), px in zip(faces, pts_all, strict=True):
            fixed = np.rint((px - (x0, y0)) * 16.0).astype(np.int32)
            cv2.fillConvexPoly(patch, fixed, int(grey), lineType=cv2.LINE_AA, shift=4)
        cols = np.arange(x0, x1)
        # the package hides nothing behind a nearer wall: compare with the column's wall
        near = np.hypot(centre[0] - cam.x, centre[1] - cam.y) - 0.5 * max(package.size[:2])
        visible = near <= ranges[cols] + world.resolution
        region[:, visible] = patch[:, visible]


__all__ = ["CameraModel", "CameraPose", "ProjectedMarker", "marker_texture"]

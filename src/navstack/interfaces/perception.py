"""Cameras, ArUco markers and the gripper on a simulated :class:`NavStack`.

:func:`attach_perception` adds to a started stack, without changing how it was built:

* :class:`~navstack.sim.camera_node.SimCameraNode` -- the robot profile's camera (image or
  corners mode, optionally at another rate);
* :class:`~navstack.nodes.aruco_detector.ArucoDetectorNode` -- detection and poses on
  ``/aruco/markers`` and ``camera -> marker_<id>`` TF;
* :class:`~navstack.nodes.marker_map.MarkerMapNode` -- markers on the map, static frames
  ``map -> aruco_marker_<id>``, the package cloud;
* :class:`~navstack.sim.gripper_node.SimGripperNode` when the profile has a gripper.

:func:`with_package_cloud` returns Nav2 parameters whose costmaps take ``/package_cloud``
as an obstacle-layer observation source (the TurtleBot course's package avoidance); pass
them to the stack before it is built.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from navstack.core.errors import ConfigError
from navstack.interfaces.stack import NavStack
from navstack.nodes.aruco_detector import ArucoDetectorNode, ArucoNodeParams
from navstack.nodes.marker_map import MarkerMapNode, MarkerMapNodeParams
from navstack.perception.aruco import ArucoParams
from navstack.sim.camera_node import SimCameraNode
from navstack.sim.gripper_node import SimGripperNode

PACKAGE_CLOUD_SOURCE: dict[str, Any] = {
    "topic": "/package_cloud", "data_type": "PointCloud2", "sensor_frame": "base_link",
    "marking": True, "clearing": False, "min_obstacle_height": 0.0,
    "max_obstacle_height": 0.1, "obstacle_max_range": 50.0, "obstacle_min_range": 0.0,
    "observation_persistence": 0.0, "expected_update_rate": 0.0}
"""The course's ``package_cloud`` source: marking only, the ring's z 0.05 inside the
0 .. 0.1 m band, origin at the robot so every package on the map is within range."""


def with_package_cloud(nav2_params: Mapping[str, Any],
                       costmaps: tuple[str, ...] = ("global_costmap", "local_costmap"),
                       global_update_frequency: float | None = 5.0) -> dict[str, Any]:
    """A copy of Nav2 parameters whose costmaps' obstacle layers also read
    ``/package_cloud``.  ``global_update_frequency`` (Hz, ``None``: keep) raises the
    global costmap's rate so a package is in it within the course's 0.4 s response."""
    out = copy.deepcopy(dict(nav2_params))
    for name in costmaps:
        try:
            section = out[name][name]["ros__parameters"]
        except (KeyError, TypeError):
            raise ConfigError(f"no {name} section", key_path=f"{name}.{name}.ros__parameters",
                              suggestion="use a Nav2 parameter file with both costmaps") from None
        layers = [n for n in section.get("plugins", [])
                  if "ObstacleLayer" in str(section.get(n, {}).get("plugin", ""))
                  or "VoxelLayer" in str(section.get(n, {}).get("plugin", ""))]
        if not layers:
            raise ConfigError(f"{name} has no obstacle layer to feed /package_cloud to",
                              key_path=f"{name}.plugins")
        layer = section[layers[0]]
        sources = layer.get("observation_sources", "")
        names = sources.split() if isinstance(sources, str) else list(sources)
        if "package_cloud" not in names:
            names.append("package_cloud")
        layer["observation_sources"] = " ".join(names)
        layer["package_cloud"] = dict(PACKAGE_CLOUD_SOURCE)
        if name == "global_costmap" and global_update_frequency is not None:
            section["update_frequency"] = max(float(section.get("update_frequency", 1.0)),
                                              global_update_frequency)
    return out


@dataclass
class PerceptionOptions:
    """What :func:`attach_perception` adds and how."""

    camera_mode: Literal["image", "corners"] | None = None
    """``None``: the robot profile's."""
    camera_rate_hz: float | None = None
    detector: ArucoParams | Mapping[str, Any] = field(default_factory=dict)
    marker_map: MarkerMapNodeParams | Mapping[str, Any] = field(default_factory=dict)
    gripper: bool = True


@dataclass
class Perception:
    """The perception nodes running on a stack."""

    camera: SimCameraNode
    detector: ArucoDetectorNode
    marker_map: MarkerMapNode
    gripper: SimGripperNode | None


def attach_perception(stack: NavStack, options: PerceptionOptions | None = None) -> Perception:
    """Start ``stack`` if needed and add the perception nodes (module docstring)."""
    opts = options or PerceptionOptions()
    stack.start()
    rt = stack.runtime
    cam = stack.robot.sensors.camera
    if not cam.enabled:
        raise ConfigError(f"robot '{stack.robot.name}' has no camera",
                          key_path="robot.sensors.camera.enabled",
                          suggestion="enable the camera in the robot profile")
    changes: dict[str, Any] = {}
    if opts.camera_mode is not None:
        changes["mode"] = opts.camera_mode
    if opts.camera_rate_hz is not None:
        changes["rate_hz"] = opts.camera_rate_hz
    if changes:
        cam = cam.updated(**changes)
    camera = SimCameraNode(rt, stack.sim, stack.description.seed, params=cam)
    detector_params = (opts.detector if isinstance(opts.detector, ArucoParams)
                       else ArucoParams.from_mapping(dict(opts.detector), key_path="detector"))
    node_params = ArucoNodeParams(
        input="image" if cam.mode == "image" else "vertices",
        image_topic="/" + cam.topic.lstrip("/"),
        camera_info_topic="/" + cam.info_topic.lstrip("/"),
        vertices_topic="/" + cam.corners_topic.lstrip("/"), detector=detector_params)
    detector = ArucoDetectorNode(rt, node_params)
    map_params = (opts.marker_map if isinstance(opts.marker_map, MarkerMapNodeParams)
                  else MarkerMapNodeParams.from_mapping(dict(opts.marker_map),
                                                        key_path="marker_map"))
    marker_map = MarkerMapNode(rt, map_params)
    gripper = (SimGripperNode(rt, stack.sim) if opts.gripper and stack.robot.gripper.enabled
               else None)
    rt.bring_up()
    return Perception(camera, detector, marker_map, gripper)


__all__ = ["PACKAGE_CLOUD_SOURCE", "Perception", "PerceptionOptions", "attach_perception",
           "with_package_cloud"]

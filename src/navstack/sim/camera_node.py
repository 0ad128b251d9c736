"""``SimCameraNode``: the simulated camera of a robot profile on the bus.

Samples :class:`~navstack.sim.camera.CameraModel` at the camera's ``rate_hz`` from the
simulator's current state (it first advances the simulator node's physics to ``now``,
like every simulated sensor) and publishes, with the profile's topic names:

* image mode: ``/camera/image_raw`` (sensor_msgs/Image) and ``/camera/camera_info``;
* corners mode: ``/fiducial_vertices`` (fiducial_msgs/FiducialArray) and the camera info.

``/tf_static`` gets ``base_link -> <frame_id>`` (the mount) and ``<frame_id> ->
<optical_frame>`` (the REP-103 optical rotation: z forward, x right, y down).  The
camera draws from its own random stream (``[seed, 3]``) so adding a camera leaves every
other sensor's noise, and so existing seeded runs, unchanged.
"""

from __future__ import annotations

import numpy as np

from navstack.core.errors import ConfigError
from navstack.core.msgs import Header, TFMessage, Transform, TransformStamped, Vector3
from navstack.core.msgs.camera_msgs import CameraInfo, Image
from navstack.core.msgs.fiducial_msgs import FiducialArray
from navstack.core.msgs.geometry_msgs import Quaternion
from navstack.runtime.bus import SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime
from navstack.sim.camera import CameraModel
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import CameraParams

OPTICAL_ROTATION = Quaternion(-0.5, 0.5, -0.5, 0.5)
"""Rotation of an optical frame in its body frame (x right, y down, z forward)."""


def _topic(name: str) -> str:
    return name if name.startswith("/") else "/" + name


class SimCameraNode(Node):
    """Publishes the robot profile's camera (see module docstring)."""

    def __init__(self, runtime: Runtime, sim_node: SimulatorNode, seed: int = 0,
                 name: str = "camera", params: CameraParams | None = None) -> None:
        """``params``: the camera to simulate (default: the robot profile's)."""
        super().__init__(name, runtime)
        params = params or sim_node.sim.robot.sensors.camera
        if not params.enabled:
            raise ConfigError("the robot profile's camera is disabled",
                              key_path="robot.sensors.camera.enabled",
                              suggestion="set it to true to simulate the camera")
        self.sim_node = sim_node
        self.params = params
        self.model = CameraModel(params)
        self.rng = np.random.default_rng([seed, 3])
        self.frames = 0

    def on_configure(self) -> None:
        p = self.params
        self.pub_info = self.create_publisher(_topic(p.info_topic), CameraInfo, SENSOR_DATA)
        if p.mode == "image":
            self.pub_image = self.create_publisher(_topic(p.topic), Image, SENSOR_DATA)
        else:
            self.pub_corners = self.create_publisher(_topic(p.corners_topic), FiducialArray,
                                                     QoS(depth=10))
        self.pub_tf_static = self.create_publisher("/tf_static", TFMessage,
                                                   QoS(depth=1, latched=True))
        self.create_timer(1.0 / p.rate_hz, self._sample)

    def on_activate(self) -> None:
        p = self.params
        m = p.mount
        base = self.sim_node.sim.robot.base_frame_id
        self.pub_tf_static.publish(TFMessage((
            TransformStamped(Header(self.now, base), p.frame_id,
                             Transform(Vector3(m.x, m.y, m.z), Quaternion.from_yaw(m.yaw))),
            TransformStamped(Header(self.now, p.frame_id), p.optical_frame,
                             Transform(Vector3(), OPTICAL_ROTATION)))))

    def _sample(self) -> None:
        self.sim_node.advance()
        sim, now = self.sim_node.sim, self.now
        world = sim.world
        moving = world.moving_at(sim.obstacle_clocks) if world.moving_obstacles else None
        poses = sim.packages.poses if world.packages else None
        if self.params.mode == "image":
            self.pub_image.publish(self.model.image(world, sim.pose, self.rng, now, moving,
                                                    poses, sim.state.wz))
        else:
            self.pub_corners.publish(self.model.fiducials(world, sim.pose, self.rng, now,
                                                          moving, poses, self.frames))
        self.pub_info.publish(self.model.camera_info(now))
        self.frames += 1


__all__ = ["OPTICAL_ROTATION", "SimCameraNode"]

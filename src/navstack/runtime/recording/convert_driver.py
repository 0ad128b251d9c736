"""navstack <-> ROS 2 conversions of the vehicle-link messages: sensor_msgs/JointState,
sensor_msgs/PointCloud2 and PointField (written with every field, as the simulated
multi-ring lidar publishes them), diagnostic_msgs/DiagnosticStatus, DiagnosticArray and
KeyValue.  A ROS ``PointCloud2`` read from a bag still becomes navstack's xyz
``PointCloud`` (:mod:`.convert_sensor`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.core.msgs import (
    DiagnosticArray,
    DiagnosticStatus,
    JointState,
    KeyValue,
    PointCloud2,
    PointField,
)
from navstack.runtime.recording.convert_geometry import from_header, to_header


def to_joint_state(m: JointState, r: Any) -> Any:
    return r.JointState(header=to_header(m.header, r), name=list(m.name),
                        position=np.asarray(m.position, np.float64),
                        velocity=np.asarray(m.velocity, np.float64),
                        effort=np.asarray(m.effort, np.float64))


def from_joint_state(o: Any) -> JointState:
    return JointState(from_header(o.header), tuple(str(n) for n in o.name),
                      tuple(float(v) for v in o.position), tuple(float(v) for v in o.velocity),
                      tuple(float(v) for v in o.effort))


def to_point_field(m: PointField, r: Any) -> Any:
    return r.PointField(name=m.name, offset=int(m.offset), datatype=int(m.datatype),
                        count=int(m.count))


def from_point_field(o: Any) -> PointField:
    return PointField(str(o.name), int(o.offset), int(o.datatype), int(o.count))


def to_point_cloud2(m: PointCloud2, r: Any) -> Any:
    return r.PointCloud2(header=to_header(m.header, r), height=int(m.height),
                         width=int(m.width), fields=[to_point_field(f, r) for f in m.fields],
                         is_bigendian=bool(m.is_bigendian), point_step=int(m.point_step),
                         row_step=int(m.row_step),
                         data=np.ascontiguousarray(m.data, dtype=np.uint8).reshape(-1),
                         is_dense=bool(m.is_dense))


def to_key_value(m: KeyValue, r: Any) -> Any:
    return r.KeyValue(key=m.key, value=m.value)


def from_key_value(o: Any) -> KeyValue:
    return KeyValue(str(o.key), str(o.value))


def to_diagnostic_status(m: DiagnosticStatus, r: Any) -> Any:
    return r.DiagnosticStatus(level=int(m.level), name=m.name, message=m.message,
                              hardware_id=m.hardware_id,
                              values=[to_key_value(v, r) for v in m.values])


def from_diagnostic_status(o: Any) -> DiagnosticStatus:
    return DiagnosticStatus(int(o.level), str(o.name), str(o.message), str(o.hardware_id),
                            tuple(from_key_value(v) for v in o.values))


def to_diagnostic_array(m: DiagnosticArray, r: Any) -> Any:
    return r.DiagnosticArray(header=to_header(m.header, r),
                             status=[to_diagnostic_status(s, r) for s in m.status])


def from_diagnostic_array(o: Any) -> DiagnosticArray:
    return DiagnosticArray(from_header(o.header),
                           tuple(from_diagnostic_status(s) for s in o.status))


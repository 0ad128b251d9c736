"""visualization_msgs/MarkerArray to a Foxglove ``SceneUpdate`` (cubes, cylinders,
spheres and texts), for the marker map's ``/aruco/marker_map/markers`` in Foxglove live."""

from __future__ import annotations

from foxglove import messages as fm

from navstack.core.msgs import Marker, MarkerArray


def _pose(m: Marker) -> fm.Pose:
    p, q = m.pose.position, m.pose.orientation
    return fm.Pose(position=fm.Vector3(x=p.x, y=p.y, z=p.z),
                   orientation=fm.Quaternion(x=q.x, y=q.y, z=q.z, w=q.w))


def marker_array_scene(msg: MarkerArray, stamp_ns: int) -> fm.SceneUpdate:
    """One scene entity per marker namespace and id; unsupported types are skipped."""
    entities = []
    ts = fm.Timestamp(sec=stamp_ns // 1_000_000_000, nsec=stamp_ns % 1_000_000_000)
    for m in msg.markers:
        if m.action != Marker.ADD:
            continue
        color = fm.Color(r=m.color.r, g=m.color.g, b=m.color.b, a=m.color.a)
        size = fm.Vector3(x=m.scale.x, y=m.scale.y, z=m.scale.z)
        kwargs: dict[str, list[object]] = {}
        if m.type == Marker.CUBE:
            kwargs["cubes"] = [fm.CubePrimitive(pose=_pose(m), size=size, color=color)]
        elif m.type == Marker.CYLINDER:
            kwargs["cylinders"] = [fm.CylinderPrimitive(pose=_pose(m), size=size,
                                                        bottom_scale=1.0, top_scale=1.0,
                                                        color=color)]
        elif m.type == Marker.SPHERE:
            kwargs["spheres"] = [fm.SpherePrimitive(pose=_pose(m), size=size, color=color)]
        elif m.type == Marker.TEXT_VIEW_FACING:
            kwargs["texts"] = [fm.TextPrimitive(pose=_pose(m), billboard=True,
                                                font_size=m.scale.z, scale_invariant=False,
                                                color=color, text=m.text)]
        else:
            continue
        entities.append(fm.SceneEntity(timestamp=ts, frame_id=m.header.frame_id or "map",
                                       id=f"{m.ns}/{m.id}", **kwargs))  # type: ignore[arg-type]
    return fm.SceneUpdate(entities=entities)


__all__ = ["marker_array_scene"]

"""Save and reload a SLAM session: pose graph + scans (slam_toolbox serialize/deserialize).

slam_toolbox writes ``NAME.posegraph`` + ``NAME.data``; navstack writes one
``NAME.posegraph`` file, a NumPy ``.npz`` archive holding

* ``params`` (JSON of the :class:`SlamParams`), the laser geometry;
* per node: odometry pose, stamp, ranges (float32);
* the pose graph (:meth:`PoseGraph.to_dict`, bit-exact estimate);
* the running buffer and the last accepted odometry, so mapping continues seamlessly.

Reloading gives a :class:`SlamMapper` that either continues mapping (``mode="mapping"``)
or localizes against the frozen graph (``mode="localization"``).  With
``start_pose=None`` the robot is assumed to continue in the same odometry frame (the same
run, or a robot whose odometry survived the restart): ``map -> odom`` is restored exactly.
A ``start_pose`` (the robot's map pose now, slam_toolbox's ``map_start_pose``) instead
places the next scan there, as after a reboot with a fresh odometry frame.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import NavstackError
from navstack.mapping.icp import line_normals
from navstack.mapping.pose_graph import PoseGraph
from navstack.mapping.slam import LaserGeometry, ScanNode, SlamMapper
from navstack.mapping.slam_params import SlamParams

__all__ = ["PoseGraphFileError", "load_posegraph", "save_posegraph"]

FORMAT_VERSION = 1


class PoseGraphFileError(NavstackError):
    """A ``.posegraph`` file is missing, damaged or from another format version."""


def save_posegraph(mapper: SlamMapper, path: str | Path) -> Path:
    """Write the session to ``path`` (``.posegraph`` is appended if missing)."""
    out = Path(path)
    if out.suffix != ".posegraph":
        out = out.with_name(out.name + ".posegraph")
    out.parent.mkdir(parents=True, exist_ok=True)
    if not mapper.nodes:
        raise PoseGraphFileError(f"{out}: nothing to save, the SLAM session has no scans yet")
    graph = {f"graph_{k}": v for k, v in mapper.graph.to_dict().items()}
    state = mapper.state()
    arrays: dict[str, Any] = {
        "format_version": np.array(FORMAT_VERSION),
        "params": np.array(json.dumps(mapper.params.model_dump())),
        "laser_angles": mapper.laser.angles,
        "laser_limits": np.array([mapper.laser.range_min, mapper.laser.range_max]),
        "laser_mount": mapper.laser.mount,
        "node_odom": np.array([n.odom for n in mapper.nodes]),
        "node_stamp": np.array([n.stamp for n in mapper.nodes]),
        "node_ranges": np.stack([n.ranges for n in mapper.nodes]),
        "running": np.array(state["running"], dtype=np.int64),
        "map_to_odom": state["map_to_odom"],
        "last_odom": state["last_odom"],
        "last_stamp": np.array(state["last_stamp"]),
        "odometry_noise": state["odometry_noise"],
        **graph,
    }
    with out.open("wb") as fh:
        np.savez_compressed(fh, **arrays)
    return out


def load_posegraph(path: str | Path, params: SlamParams | None = None,
                   mode: str | None = None,
                   start_pose: NDArray[np.float64] | None = None) -> SlamMapper:
    """Rebuild a :class:`SlamMapper` from ``path``.

    ``params`` default to the saved ones; ``mode`` ("mapping" / "localization") overrides
    theirs.  See the module docstring for ``start_pose``."""
    src = Path(path)
    if not src.is_file():
        raise PoseGraphFileError(f"{src}: no such pose graph file; write one with "
                                 "`navstack slam LOG --out DIR` (DIR/map.posegraph) or "
                                 "SlamMapper serialization")
    try:
        with np.load(src, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise PoseGraphFileError(f"{src}: not a navstack pose graph file ({exc})") from None
    version = int(arrays.get("format_version", -1))
    if version != FORMAT_VERSION:
        raise PoseGraphFileError(f"{src}: pose graph format version {version}, this navstack "
                                 f"reads version {FORMAT_VERSION}")
    saved = SlamParams.from_mapping(json.loads(str(arrays["params"])), file=str(src))
    chosen = params if params is not None else saved
    if mode is not None:
        chosen = chosen.updated(mode=mode)
    limits = arrays["laser_limits"]
    laser = LaserGeometry(np.asarray(arrays["laser_angles"], float), float(limits[0]),
                          float(limits[1]), np.asarray(arrays["laser_mount"], float))
    mapper = SlamMapper(chosen, laser)
    graph_data = {k[len("graph_"):]: v for k, v in arrays.items() if k.startswith("graph_")}
    mapper.graph = PoseGraph.from_dict(graph_data)
    for k, (odom, stamp, ranges) in enumerate(zip(arrays["node_odom"], arrays["node_stamp"],
                                                 arrays["node_ranges"], strict=True)):
        points = mapper.scan_points(ranges)
        normals, line_like = line_normals(points)
        mapper.nodes.append(ScanNode(k, np.asarray(odom, float), float(stamp),
                                     np.asarray(ranges, np.float32), points, normals,
                                     line_like))
    mapper.restore_state(running=[int(i) for i in arrays["running"]],
                         map_to_odom=np.asarray(arrays["map_to_odom"], float),
                         last_odom=np.asarray(arrays["last_odom"], float),
                         last_stamp=float(arrays["last_stamp"]), start_pose=start_pose,
                         odometry_noise=arrays.get("odometry_noise"))
    return mapper

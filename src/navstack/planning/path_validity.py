"""Path validity (Nav2 ``nav2_planner`` ``IsPathValid`` service) and path curvature.

:func:`is_path_valid` answers what the ``IsPathValid`` service answers, with the same
request fields (``max_cost``, ``consider_unknown_as_obstacle``, ``layer_name``,
``footprint``, ``stop_at_first_collision``, ``max_lookahead_distance``) and the same
rules:

* the check starts at the path pose closest to ``robot_pose`` (poses already passed may
  have become occupied) and, with ``max_lookahead_distance > 0``, stops after that much
  integrated path length;
* without a footprint each pose is a point: its cell cost, LETHAL outside the costmap; a
  pose is invalid when the cost is ``>= max_cost``, LETHAL or INSCRIBED (for a circular
  robot the inscribed band already means contact);
* with a footprint (a polygon, placed at each pose's heading) the cost is the maximum cost
  under the footprint (:func:`navstack.costmap.footprint.footprint_cost`, LETHAL if a
  vertex leaves the map); a pose is invalid when that cost is LETHAL or ``>= max_cost``;
* unknown space (255) is LETHAL with ``consider_unknown_as_obstacle``, otherwise free.

``max_cost`` defaults to 253 (INSCRIBED) here; Nav2's service default is 254, which for a
point check is equivalent (INSCRIBED is invalid there anyway) and for a footprint check
lets the inscribed band through.  The result carries the first invalid index and a
sentence saying why, so a behavior tree can log it and replan.

:func:`path_curvature` and :func:`min_turning_radius` measure how tight a path turns
(the Menger curvature of each pose and its neighbours), for kinematic checks of
Hybrid-A* / Reeds-Shepp paths.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import InvalidMessage
from navstack.core.msgs import Path, Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)
from navstack.costmap.footprint import footprint_costs
from navstack.costmap.layer import CostmapLayer
from navstack.costmap.layered_costmap import LayeredCostmap

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PathValidity:
    """Result of :func:`is_path_valid` (Nav2 ``IsPathValid`` response).

    ``first_invalid_index`` is -1 for a valid path; ``invalid_indices`` lists every
    invalid pose checked (only the first with ``stop_at_first_collision``); ``costs`` the
    cost used for each checked pose (after the unknown-space rule), ``checked`` the
    ``[begin, end)`` index range that was checked.
    """

    is_valid: bool
    first_invalid_index: int = -1
    reason: str = ""
    invalid_indices: tuple[int, ...] = ()
    costs: NDArray[np.int32] | None = None
    checked: tuple[int, int] = (0, 0)

    def __bool__(self) -> bool:
        return self.is_valid


def _grid(costmap: Costmap2D | LayeredCostmap, layer_name: str) -> Costmap2D:
    if not layer_name:
        return costmap.costmap if isinstance(costmap, LayeredCostmap) else costmap
    if not isinstance(costmap, LayeredCostmap):
        raise InvalidMessage(f"layer_name '{layer_name}' needs a LayeredCostmap, got a "
                             f"Costmap2D; pass the layered costmap or leave layer_name empty")
    layer = costmap.layer(layer_name)
    if not isinstance(layer, CostmapLayer):
        raise InvalidMessage(f"layer '{layer_name}' ({type(layer).__name__}) has no costmap "
                             f"of its own; name a static/obstacle/voxel layer")
    return layer.costmap


def _check_range(xy: FloatArray, robot_pose: Pose2D | None,
                 max_lookahead_distance: float) -> tuple[int, int]:
    """``[begin, end)``: closest pose to the robot, then Nav2
    ``first_after_integrated_distance``."""
    n = len(xy)
    begin = 0
    if robot_pose is not None:
        begin = int(np.argmin(np.hypot(xy[:, 0] - robot_pose.x, xy[:, 1] - robot_pose.y)))
    end = n
    if max_lookahead_distance > 0.0:
        seg = np.hypot(*np.diff(xy[begin:], axis=0).T)
        beyond = np.nonzero(np.cumsum(seg) > max_lookahead_distance)[0]
        if len(beyond):
            end = begin + int(beyond[0]) + 1
    return begin, end


def is_path_valid(path: Path, costmap: Costmap2D | LayeredCostmap, *,
                  footprint: Footprint | None = None, max_cost: int = INSCRIBED_INFLATED_OBSTACLE,
                  consider_unknown_as_obstacle: bool = False, layer_name: str = "",
                  robot_pose: Pose2D | None = None, max_lookahead_distance: float = -1.0,
                  stop_at_first_collision: bool = True) -> PathValidity:
    """Check ``path`` against ``costmap`` (rules in the module docstring).

    ``layer_name`` checks one layer's own grid of a ``LayeredCostmap`` instead of the
    master grid.  The path must be in the costmap's frame (``InvalidMessage`` otherwise).
    """
    grid = _grid(costmap, layer_name)
    frame = path.header.frame_id
    if frame and grid.frame_id and frame != grid.frame_id:
        raise InvalidMessage(f"path is in frame '{frame}' but the costmap is in "
                             f"'{grid.frame_id}'; transform the path before checking it")
    xyt = path.as_array()
    if len(xyt) == 0:
        return PathValidity(False, -1, "the path has no poses")
    begin, end = _check_range(xyt[:, :2], robot_pose, max_lookahead_distance)
    poses = np.ascontiguousarray(xyt[begin:end])
    mx, my, inside = grid.world_to_map_array(poses[:, :2])
    if footprint is None:
        raw = np.full(len(poses), LETHAL_OBSTACLE, dtype=np.int32)
        raw[inside] = grid.data[my[inside], mx[inside]]
    else:
        raw = footprint_costs(grid, poses, footprint)
    unknown = raw == NO_INFORMATION
    cost = np.where(unknown, LETHAL_OBSTACLE if consider_unknown_as_obstacle else FREE_SPACE,
                    raw).astype(np.int32)
    bad = (cost >= max_cost) | (cost == LETHAL_OBSTACLE)
    if footprint is None:
        bad |= cost == INSCRIBED_INFLATED_OBSTACLE
    idx = np.nonzero(bad)[0]
    if len(idx) == 0:
        return PathValidity(True, -1, "", (), cost, (begin, end))
    if stop_at_first_collision:
        idx = idx[:1]
    k = int(idx[0])
    first = begin + k
    where = f"pose {first} at ({poses[k, 0]:.2f}, {poses[k, 1]:.2f})"
    what = "footprint" if footprint is not None else "cell"
    if footprint is None and not inside[k]:
        why = "is outside the costmap (counted as lethal)"
    elif unknown[k]:
        why = f"{what} is in unknown space and consider_unknown_as_obstacle is true"
    elif cost[k] == LETHAL_OBSTACLE:
        why = ("cell is in a lethal obstacle (cost 254)" if footprint is None else
               "footprint touches a lethal obstacle or leaves the costmap (cost 254)")
    elif cost[k] == INSCRIBED_INFLATED_OBSTACLE and footprint is None:
        why = "is in the inscribed band (cost 253): the robot would touch an obstacle"
    else:
        why = f"{what} cost {int(cost[k])} is at or above max_cost {max_cost}"
    return PathValidity(False, first, f"{where} {why}", tuple(int(begin + i) for i in idx),
                        cost, (begin, end))


def _xy(path: Path | FloatArray) -> FloatArray:
    xy = path.as_array() if isinstance(path, Path) else np.asarray(path, dtype=np.float64)
    if xy.ndim != 2 or xy.shape[1] not in (2, 3):
        raise InvalidMessage(f"path must be a Path or an (N, 2)/(N, 3) array, got shape "
                             f"{xy.shape}")
    return xy[:, :2]


def path_curvature(path: Path | FloatArray) -> FloatArray:
    """Signed curvature [1/m] at every pose, ``(N,)`` (positive turning left).

    The Menger curvature of each pose and its two neighbours: ``2 (a x b) / (|a| |b|
    |a + b|)`` with ``a``, ``b`` the displacements into and out of the pose, i.e. one over
    the radius of the circle through the three points (exact for poses on a circle).  End
    poses, repeated points and cusps (``a . b < 0``, where the robot stops and reverses)
    get 0.
    """
    xy = _xy(path)
    n = len(xy)
    out = np.zeros(n)
    if n < 3:
        return out
    a = xy[1:-1] - xy[:-2]
    b = xy[2:] - xy[1:-1]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]
    la, lb = np.hypot(a[:, 0], a[:, 1]), np.hypot(b[:, 0], b[:, 1])
    c = a + b
    denom = la * lb * np.hypot(c[:, 0], c[:, 1])
    ok = (denom > 1e-300) & (dot >= 0.0)
    out[1:-1] = np.where(ok, 2.0 * cross / np.where(ok, denom, 1.0), 0.0)
    return out


def min_turning_radius(path: Path | FloatArray) -> float:
    """Smallest turning radius along the path [m]: ``1 / max |curvature|`` (``inf`` if
    the path never turns)."""
    k = float(np.max(np.abs(path_curvature(path)), initial=0.0))
    return math.inf if k == 0.0 else 1.0 / k

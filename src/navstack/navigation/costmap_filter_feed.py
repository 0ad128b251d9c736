"""Bus side of the costmap filters of one :class:`~navstack.navigation.costmap_node.CostmapNode`.

For each filter in the costmap's ``filters:`` list (Nav2 ``CostmapFilter::onInitialize``
and the filters' callbacks):

1. subscribe (latched) to its ``filter_info_topic``; a CostmapFilterInfo the filter
   cannot read is logged and counted (``errors``), the previous one stays;
2. on each info, (re)subscribe (latched) to the ``filter_mask_topic`` it names, dropping
   the previous mask subscription as Nav2 does;
3. before each costmap update, hand a received mask to the filter with the pose of the
   mask frame in the costmap frame from TF, and keep that pose current (it moves under an
   ``odom`` costmap when localization corrects ``map -> odom``); a mask whose frame TF
   cannot place yet waits;
4. speed filters: after each update, publish ``nav2_msgs/SpeedLimit`` on
   ``speed_limit_topic`` when the limit changed; with ``enable_path_lookahead`` also feed
   the plan (``path_topic``, transformed into the costmap frame) and the robot's speed
   (``odom_topic``, averaged over 0.3 s like Nav2's ``OdomSmoother``).
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from navstack.core.errors import ConfigError, InvalidMessage, TransformError
from navstack.core.geometry import se2_compose
from navstack.core.msgs import (
    CostmapFilterInfo,
    Header,
    OccupancyGrid,
    Odometry,
    Path,
    Pose2D,
    SpeedLimit,
)
from navstack.costmap.costmap_filter import CostmapFilter
from navstack.costmap.speed_filter import SpeedFilter
from navstack.runtime.bus import LATCHED, Publisher, QoS, Subscription

if TYPE_CHECKING:
    from navstack.navigation.costmap_node import CostmapNode

ODOM_SMOOTHING_S = 0.3
"""Nav2 ``OdomSmoother`` window used by the speed filter's lookahead [s]."""

log = logging.getLogger("navstack.costmap_filters")


def _topic(name: str) -> str:
    return "/" + name.lstrip("/")


@dataclass
class _FilterState:
    """Bus state of one filter."""

    layer: CostmapFilter
    mask_sub: Subscription[OccupancyGrid] | None = None
    mask: OccupancyGrid | None = None
    info: CostmapFilterInfo | None = None
    limit_pub: Publisher[SpeedLimit] | None = None
    path: Path | None = None
    speeds: deque[tuple[float, float]] = field(default_factory=deque)
    path_cache: tuple[Path, Pose2D | None] | None = None


class CostmapFilterFeed:
    """Feeds the filters of ``node.layered`` from the bus; see the module docstring."""

    def __init__(self, node: CostmapNode) -> None:
        self.node = node
        self.states = [_FilterState(f) for f in node.layered.filters
                       if isinstance(f, CostmapFilter)]
        self.errors = 0
        self.last_error = ""
        for state in self.states:
            if not state.layer.params.filter_info_topic:
                raise ConfigError("required key is missing", key_path=(
                    f"{node.name}.{state.layer.name}.filter_info_topic"),
                    suggestion="name the CostmapFilterInfo topic of the filter's "
                               "costmap_filter_info_server")

    def configure(self) -> None:
        node = self.node
        for state in self.states:
            layer = state.layer
            node.create_subscription(_topic(layer.params.filter_info_topic),
                                     CostmapFilterInfo, partial(self._on_info, state), LATCHED)
            if isinstance(layer, SpeedFilter):
                p = layer.params
                state.limit_pub = node.create_publisher(_topic(p.speed_limit_topic),
                                                        SpeedLimit, QoS(depth=10))
                if p.enable_path_lookahead:
                    node.create_subscription(_topic(p.path_topic), Path,
                                             partial(self._on_path, state), QoS(depth=1))
                    node.create_subscription(_topic(p.odom_topic), Odometry,
                                             partial(self._on_odom, state), QoS(depth=10))

    # --- callbacks ---------------------------------------------------------------------
    def _on_info(self, state: _FilterState, info: CostmapFilterInfo) -> None:
        try:
            state.layer.check_filter_info(info)
        except ConfigError as exc:
            self._error(f"{self.node.name}: ignoring filter info for '{state.layer.name}': "
                        f"{exc}")
            return
        state.info = info
        state.layer.set_filter_info(info)  # a mask already held is read the new way
        if state.mask_sub is not None:  # Nav2 resets the mask subscription on new info
            self.node.destroy_subscription(state.mask_sub)
        state.mask_sub = self.node.create_subscription(
            _topic(info.filter_mask_topic), OccupancyGrid, partial(self._on_mask, state),
            QoS(depth=3, latched=True))

    def _on_mask(self, state: _FilterState, mask: OccupancyGrid) -> None:
        state.mask = mask

    def _on_path(self, state: _FilterState, path: Path) -> None:
        state.path = path

    def _on_odom(self, state: _FilterState, odom: Odometry) -> None:
        tw = odom.twist.twist
        state.speeds.append((odom.header.stamp, float(np.hypot(tw.linear.x, tw.linear.y))))

    def _error(self, text: str) -> None:
        self.errors += 1
        self.last_error = text
        log.error(text)

    # --- update hooks ------------------------------------------------------------------
    def before_update(self) -> None:
        """Hand over masks and keep their placement, plan and speed current."""
        for state in self.states:
            if state.mask is None:
                continue
            known, placed = self._mask_in_costmap(state.mask)
            if not known:
                continue
            layer = state.layer
            if layer.mask is not state.mask:
                try:
                    layer.set_mask(state.mask, state.info, placed)
                except (ConfigError, InvalidMessage) as exc:
                    self._error(f"{self.node.name}: ignoring mask for '{layer.name}': {exc}")
                    state.mask = None
                    continue
            else:
                layer.set_mask_in_costmap(placed)
            if isinstance(layer, SpeedFilter) and layer.params.enable_path_lookahead:
                self._feed_lookahead(state, layer)

    def after_update(self) -> None:
        """Publish speed limits that changed in this update."""
        for state in self.states:
            layer = state.layer
            if isinstance(layer, SpeedFilter) and state.limit_pub is not None:
                change = layer.pop_speed_limit()
                if change is not None:
                    state.limit_pub.publish(SpeedLimit(
                        Header(self.node.now, self.node.global_frame), change[1], change[0]))

    def _mask_in_costmap(self, mask: OccupancyGrid) -> tuple[bool, Pose2D | None]:
        """``(known, pose)``: the pose of the mask frame in the costmap frame (``None``:
        the same frame); ``known`` is false while TF cannot tell yet."""
        frame = mask.header.frame_id
        node = self.node
        if not frame or frame == node.global_frame:
            return True, None
        try:
            return True, node.tf.lookup_pose2d(node.global_frame, frame)
        except TransformError as exc:
            node.tf_failed(exc)
            return False, None

    def _feed_lookahead(self, state: _FilterState, layer: SpeedFilter) -> None:
        now = self.node.now
        speeds = state.speeds
        while speeds and speeds[0][0] < now - ODOM_SMOOTHING_S:
            speeds.popleft()
        if speeds:
            layer.set_robot_speed(sum(v for _, v in speeds) / len(speeds))
        path = state.path
        if path is None or not path.num_poses:
            if layer.path_xy is not None:
                layer.set_path(None)
            return
        frame = path.header.frame_id
        moved: Pose2D | None = None
        if frame and frame != self.node.global_frame:
            try:
                moved = self.node.tf.lookup_pose2d(self.node.global_frame, frame)
            except TransformError as exc:
                self.node.tf_failed(exc)
                return
        cached = state.path_cache
        if cached is not None and cached[0] is path and cached[1] == moved:
            return
        xyt = path.as_array()
        if moved is not None:
            xyt = se2_compose(moved.as_array(), xyt)
        layer.set_path(xyt[:, :2])
        state.path_cache = (path, moved)

"""Fault injection into a running simulated :class:`~navstack.interfaces.stack.NavStack`.

Each fault breaks one contract of the textbook's decision tree, through the stack's public
objects only (no shared file is edited), and can be reverted:

* ``tf_map_odom`` / ``tf_odom_base`` -- the TF publisher of ``map -> odom`` (localization)
  or ``odom -> base_link`` (odometry) stops: every node's ``/tf`` publisher is wrapped in a
  filter that drops that edge;
* ``controller_inactive`` -- the controller server is deactivated (lifecycle
  ``deactivate``), as when a Nav2 lifecycle manager brings up only part of the stack;
* ``cmd_vel_ignored`` -- the base stops listening: the simulator's ``/cmd_vel``
  subscription is removed (a driver subscribed to another topic name);
* ``costmap_lethal`` -- a layer that marks every cell lethal is appended to both costmaps
  (an obstacle layer fed garbage, a wrong ``lethal_cost_threshold``);
* ``progress_blocked`` -- the robot is held in place by an obstacle the lidar cannot see
  (a cable, a doorstep below the scan plane): the simulator's kinematic model is wrapped
  so the robot's centre cannot cross a line across its way to the goal, so the controller
  commands, the base tries, nothing moves and the progress checker aborts;
* ``velocity_limits_zero`` -- the DWB controller is rebuilt with ``max_vel_x``,
  ``max_speed_xy`` and ``max_vel_theta`` at 0 (a parameter file typo);
* ``healthy`` -- nothing.

:data:`FAULTS` maps each name to the contract the doctor must name for it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

from navstack.core.errors import UnknownNameError
from navstack.core.msgs import Pose2D, TFMessage, Twist2D
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from navstack.costmap.layer import Bounds, CellWindow, Layer
from navstack.interfaces.health.model import HealthError
from navstack.interfaces.stack import NavStack
from navstack.navigation.costmap_node import CostmapNode
from navstack.sim.kinematics import RobotState

FAULTS: dict[str, str] = {
    "healthy": "none",
    "tf_map_odom": "tf",
    "tf_odom_base": "tf",
    "controller_inactive": "controller_active",
    "cmd_vel_ignored": "base_consumes_cmd_vel",
    "costmap_lethal": "costmap_not_lethal",
    "progress_blocked": "progress",
    "velocity_limits_zero": "velocity_limits",
}
"""Fault name -> the contract it breaks (the doctor's expected diagnosis)."""

LETHAL_LAYER_NAME = "fault_lethal_layer"


@dataclass
class InjectedFault:
    """A fault in effect; :meth:`revert` undoes it (idempotent)."""

    name: str
    description: str
    _undo: list[Callable[[], None]] = field(default_factory=list, repr=False)

    @property
    def contract(self) -> str:
        return FAULTS[self.name]

    def revert(self) -> None:
        while self._undo:
            self._undo.pop()()


class _TfEdgeFilter:
    """Stands in for a node's ``/tf`` publisher and drops transforms of chosen child
    frames; a message left empty is not published at all (the publisher went quiet)."""

    def __init__(self, inner: Any, drop_children: frozenset[str]) -> None:
        self.inner = inner
        self.drop_children = drop_children

    def publish(self, msg: TFMessage) -> None:
        kept = tuple(t for t in msg.transforms if t.child_frame_id not in self.drop_children)
        if kept:
            self.inner.publish(TFMessage(kept) if len(kept) != len(msg.transforms) else msg)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


class LethalLayer(Layer):
    """A costmap layer that writes ``LETHAL_OBSTACLE`` into every cell of the master grid
    on every update (the ``costmap_lethal`` fault)."""

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        cm = self.master
        bounds.touch(cm.origin_x, cm.origin_y)
        bounds.touch(cm.origin_x + cm.size_x_m, cm.origin_y + cm.size_y_m)
        return bounds

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        master.data[window.slices] = LETHAL_OBSTACLE


class BarrierModel:
    """Wraps a simulator kinematic model: the robot's centre cannot move beyond the line
    ``normal . p = offset`` (an obstacle below the lidar plane).  A step that would
    take it further is not taken and the velocities drop to zero, as the simulator's
    contact model does; turning in place and backing away stay possible."""

    def __init__(self, inner: Any, normal: tuple[float, float], offset: float) -> None:
        self.inner = inner
        self.normal = normal
        self.offset = offset
        self.holonomic = bool(inner.holonomic)
        self.blocked_steps = 0

    def step(self, state: RobotState, cmd: Twist2D, dt: float) -> RobotState:
        new: RobotState = self.inner.step(state, cmd, dt)
        nx, ny = self.normal
        before = nx * state.x + ny * state.y
        after = nx * new.x + ny * new.y
        if after > self.offset and after > before:
            self.blocked_steps += 1
            return RobotState(state.x, state.y, state.yaw, 0.0, 0.0, 0.0,
                              state.steering_angle)
        return new

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


# --- the faults ------------------------------------------------------------------------
def _stop_tf_edge(stack: NavStack, child: str, fault: InjectedFault) -> None:
    wrapped = 0
    for node in stack.runtime.nodes.values():
        pub = getattr(node, "pub_tf", None)
        if pub is None:
            continue
        setattr(node, "pub_tf", _TfEdgeFilter(pub, frozenset({child})))  # noqa: B010
        fault._undo.append(lambda n=node, p=pub: setattr(n, "pub_tf", p))  # type: ignore[misc]
        wrapped += 1
    if wrapped == 0:
        raise HealthError("no node of this stack publishes /tf (no 'pub_tf' publisher); "
                          "the TF fault needs the simulator or a localization node")


def _deactivate_controller(stack: NavStack, fault: InjectedFault) -> None:
    stack.controller.deactivate()
    fault._undo.append(stack.controller.activate)


def _ignore_cmd_vel(stack: NavStack, fault: InjectedFault) -> None:
    # the simulator node's own subscriptions (Node keeps them for cleanup)
    subs = [s for s in stack.sim._subs if s.topic.name == "/cmd_vel"]
    if not subs:
        raise HealthError("the simulator is not subscribed to /cmd_vel (already ignored?)")
    for sub in subs:
        sub.unsubscribe()

    def resubscribe() -> None:
        for sub in subs:
            if sub not in sub.topic.subscriptions:
                sub.topic.subscriptions.append(sub)
                sub.enabled = True

    fault._undo.append(resubscribe)


def _lethal_costmaps(stack: NavStack, fault: InjectedFault) -> None:
    for node in (stack.global_costmap, stack.local_costmap):
        layer = LethalLayer(LETHAL_LAYER_NAME)
        node.layered.add_plugin(layer)
        node.update()

        def remove(n: CostmapNode = node, lay: LethalLayer = layer) -> None:
            if lay in n.layered.plugins:
                n.layered.plugins.remove(lay)
                n.clear_all()  # rebuild every cell from the remaining layers

        fault._undo.append(remove)


def _block_robot(stack: NavStack, goal: Pose2D | None, free_travel: float,
                 fault: InjectedFault) -> None:
    sim = stack.sim.sim
    start = sim.pose
    if goal is not None and math.hypot(goal.x - start.x, goal.y - start.y) > 1e-6:
        heading = math.atan2(goal.y - start.y, goal.x - start.x)
    else:
        heading = start.theta
    normal = (math.cos(heading), math.sin(heading))
    offset = normal[0] * start.x + normal[1] * start.y + free_travel
    inner = sim.model
    sim.model = BarrierModel(inner, normal, offset)  # type: ignore[assignment]
    fault._undo.append(lambda: setattr(sim, "model", inner))


def _zero_velocity_limits(stack: NavStack, fault: InjectedFault) -> None:
    """Rebuild every DWB controller with zero maximum velocities; a rotation shim keeps
    its place and gets the zero-limited DWB as its primary controller (the primary's
    keys live in the shim's section, as in Nav2)."""
    from navstack.control.dwb.dwb_controller import DWBLocalPlanner
    from navstack.control.rotation_shim import RotationShimController

    def zeroed(name: str, ctrl: object) -> DWBLocalPlanner:
        if not isinstance(ctrl, DWBLocalPlanner):
            raise HealthError(f"velocity_limits_zero rebuilds DWB controllers; controller "
                              f"'{name}' is {type(ctrl).__name__}")
        zero = ctrl.params.updated(max_vel_x=0.0, max_speed_xy=0.0, max_vel_theta=0.0,
                                   min_vel_x=min(ctrl.params.min_vel_x, 0.0))
        return DWBLocalPlanner(zero, footprint=stack.footprint)

    controllers = stack.controller.controllers
    originals = dict(controllers)
    for name, ctrl in originals.items():
        if isinstance(ctrl, RotationShimController):
            shim, primary = ctrl, ctrl.primary
            shim.primary = zeroed(name, primary)
            fault._undo.append(partial(setattr, shim, "primary", primary))
        else:
            controllers[name] = zeroed(name, ctrl)
    fault._undo.append(lambda: controllers.update(originals))


def inject_fault(stack: NavStack, name: str, goal: Pose2D | None = None,
                 free_travel: float = 0.3) -> InjectedFault:
    """Put fault ``name`` (a key of :data:`FAULTS`) into ``stack`` now.

    ``goal`` (``map`` frame) orients the ``progress_blocked`` barrier across the way to
    it, ``free_travel`` [m] ahead of the robot (default: across its heading).
    """
    if name not in FAULTS:
        raise UnknownNameError("fault", name, FAULTS)
    descriptions = {
        "healthy": "no fault injected",
        "tf_map_odom": "map -> odom is no longer published (localization stopped)",
        "tf_odom_base": "odom -> base_link is no longer published (odometry TF stopped)",
        "controller_inactive": "controller_server deactivated",
        "cmd_vel_ignored": "the base no longer subscribes to /cmd_vel",
        "costmap_lethal": "a layer marks every cell of both costmaps lethal",
        "progress_blocked": f"an obstacle below the lidar plane holds the robot "
                            f"{free_travel:.2f} m ahead",
        "velocity_limits_zero": "controller max_vel_x / max_speed_xy / max_vel_theta set to 0",
    }
    fault = InjectedFault(name, descriptions[name])
    if name == "tf_map_odom":
        _stop_tf_edge(stack, "odom", fault)
    elif name == "tf_odom_base":
        _stop_tf_edge(stack, stack.local_costmap.robot_base_frame, fault)
    elif name == "controller_inactive":
        _deactivate_controller(stack, fault)
    elif name == "cmd_vel_ignored":
        _ignore_cmd_vel(stack, fault)
    elif name == "costmap_lethal":
        _lethal_costmaps(stack, fault)
    elif name == "progress_blocked":
        _block_robot(stack, goal, free_travel, fault)
    elif name == "velocity_limits_zero":
        _zero_velocity_limits(stack, fault)
    return fault

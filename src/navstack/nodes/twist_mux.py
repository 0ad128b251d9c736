"""``TwistMuxNode``: twist_mux on the bus (ros-teleop ``twist_mux``).

Subscribes every input of the configuration (``geometry_msgs/Twist``, or ``TwistStamped``
with ``use_stamped``) and every lock (``std_msgs/Bool``); forwards the winning input's
messages to ``cmd_vel_out`` (``/cmd_vel``) as they arrive and publishes the zeros of
:class:`navstack.control.twist_mux.TwistMux` (a lock engaging, masked messages while
locked, the winner timing out).  A timer every ``timeout_check_period`` catches expiries
between messages (a dead lock publisher locks without waiting for a command).
``/twist_mux/locked`` (``std_msgs/Bool``, latched) is true while any lock is active and
``/twist_mux/active`` (``std_msgs/String``, latched) names the winning input ("" for none);
both are published on change.  Semantics and departures: ``docs/command_path.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from navstack.control.twist_mux import MuxAction, TwistMux, TwistMuxParams
from navstack.core.msgs import Bool, Header, String, Twist, TwistStamped
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["TwistMuxNode"]


class TwistMuxNode(Node):
    """Multiplexes velocity inputs by priority under Bool locks."""

    def __init__(self, runtime: Runtime, params: TwistMuxParams,
                 name: str = "twist_mux") -> None:
        super().__init__(name, runtime)
        self.params = params
        self.mux = TwistMux(params)
        self.forwarded = 0
        self._locked: bool | None = None
        self._active: str | None = ""
        self._frame = ""

    def on_configure(self) -> None:
        p = self.params
        msg_type: type[Any] = TwistStamped if p.use_stamped else Twist
        self.pub = self.create_publisher(p.cmd_vel_out, msg_type, QoS(depth=1))
        self.pub_locked = self.create_publisher("/twist_mux/locked", Bool, LATCHED)
        self.pub_active = self.create_publisher("/twist_mux/active", String, LATCHED)
        for entry in p.topics:
            self.create_subscription(entry.topic, msg_type, self._input_cb(entry.name),
                                     QoS(depth=1))
        for entry in p.locks:
            self.create_subscription(entry.topic, Bool, self._lock_cb(entry.name),
                                     QoS(depth=10))
        self.create_timer(p.timeout_check_period, self._tick)

    def on_activate(self) -> None:
        self._status()

    # --- callbacks -------------------------------------------------------------------------
    def _input_cb(self, name: str) -> Callable[[Twist | TwistStamped], None]:
        return lambda msg: self._on_input(name, msg)

    def _lock_cb(self, name: str) -> Callable[[Bool], None]:
        return lambda msg: self._on_lock(name, msg)

    def _on_input(self, name: str, msg: Twist | TwistStamped) -> None:
        action = self.mux.on_input(name, self.now)
        if action is MuxAction.FORWARD:
            self.forwarded += 1
            if isinstance(msg, TwistStamped):
                self._frame = msg.header.frame_id
                self.pub.publish(TwistStamped(Header(self.now, msg.header.frame_id),
                                              msg.twist))
            else:
                self.pub.publish(msg)
        else:
            self._act(action)
        self._status()

    def _on_lock(self, name: str, msg: Bool) -> None:
        self._act(self.mux.on_lock(name, msg.data, self.now))
        self._status()

    def _tick(self) -> None:
        self._act(self.mux.tick(self.now))
        self._status()

    def _act(self, action: MuxAction) -> None:
        if action is MuxAction.ZERO:
            if self.params.use_stamped:
                self.pub.publish(TwistStamped(Header(self.now, self._frame), Twist()))
            else:
                self.pub.publish(Twist())

    def _status(self) -> None:
        now = self.now
        locked = bool(self.mux.active_locks(now))
        if locked != self._locked:
            self._locked = locked
            self.pub_locked.publish(Bool(locked))
        active = self.mux.winner(now)
        if active != self._active:
            self._active = active
            self.pub_active.publish(String(active or ""))

    @property
    def locked(self) -> bool:
        """True while any lock is active."""
        return bool(self.mux.active_locks(self.now))

    def mux_state(self) -> dict[str, Any]:
        """The mux's state (winner, locks, ages) plus the forwarded-message count."""
        return {**self.mux.state(self.now), "forwarded": self.forwarded}

"""TfMessageFilter: a message waits for TF at its stamp, is released in order when TF
arrives, is dropped and counted after the timeout, and the queue is bounded."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Header, Pose2D, TFMessage
from navstack.core.tf import tf_from_pose2d, tf_to_stamped
from navstack.runtime.bus import QoS
from navstack.runtime.node import Node, Runtime
from navstack.runtime.tf_filter import TfMessageFilter


@dataclass(frozen=True)
class Stamped:
    header: Header


class Listener(Node):
    """Looks up the odometry pose at each message's stamp."""

    def __init__(self, rt: Runtime, **options: float) -> None:
        super().__init__("listener", rt)
        self.placed: list[tuple[float, float, float]] = []  # (now, stamp, odom x)
        self.dropped: list[str] = []
        self.filter: TfMessageFilter[Stamped, Pose2D] = TfMessageFilter(
            self, self._lookup, self._on_placed, what="scan",
            on_drop=lambda _, reason: self.dropped.append(reason),
            queue_size=int(options.get("queue_size", 5)), timeout=options.get("timeout", 0.5))

    def _lookup(self, msg: Stamped) -> Pose2D:
        return self.tf.lookup_pose2d("odom", "base_link", msg.header.stamp)

    def _on_placed(self, msg: Stamped, odom: Pose2D) -> None:
        self.placed.append((self.now, msg.header.stamp, odom.x))


def _rig(**options: float) -> tuple[Runtime, Listener]:
    rt = Runtime()
    node = Listener(rt, **options)
    rt.bring_up()
    return rt, node


def _publish_odom(rt: Runtime, stamp: float, x: float) -> None:
    """``odom -> base_link`` at ``stamp`` on ``/tf`` (the runtime's TF buffer ingests it)."""
    ts = tf_to_stamped(tf_from_pose2d(Pose2D(x, 0.0, 0.0)), "odom", "base_link", stamp)
    rt.bus.publisher("/tf", TFMessage, QoS(depth=100)).publish(TFMessage((ts,)))


def _msg(stamp: float) -> Stamped:
    return Stamped(Header(stamp, "laser"))


def test_message_waits_and_is_released_when_tf_at_its_stamp_arrives() -> None:
    rt, node = _rig()
    _publish_odom(rt, 0.0, 0.0)
    _publish_odom(rt, 0.1, 1.0)
    rt.scheduler.run_until(0.0)
    node.filter.add(_msg(0.15))  # odometry only up to 0.1: it waits
    assert node.placed == [] and len(node.filter.pending) == 1
    rt.scheduler.call_at(0.05, _publish_odom, rt, 0.2, 2.0)
    rt.scheduler.run_until(0.5)
    # retries every 0.02 s: the first one after the odometry of 0.2 arrived (t=0.05) is 0.06
    assert len(node.placed) == 1
    now, stamp, x = node.placed[0]
    assert now == pytest.approx(0.06) and stamp == 0.15
    assert x == pytest.approx(1.5)  # interpolated between the samples at 0.1 and 0.2
    f = node.filter
    assert (f.received, f.released, f.dropped, f.pending) == (1, 1, 0, ())


def test_message_without_tf_is_dropped_and_counted_after_the_timeout() -> None:
    rt, node = _rig(timeout=0.1)
    node.filter.add(_msg(0.0))
    rt.scheduler.run_until(0.09)
    assert node.filter.dropped_timeout == 0 and len(node.filter.pending) == 1
    rt.scheduler.run_until(0.3)
    f = node.filter
    assert f.dropped_timeout == 1 and f.released == 0 and f.pending == ()
    assert node.placed == [] and node.dropped == [f.last_drop]
    assert f.last_drop.startswith("scan at t=0.000 dropped: ") and "'odom'" in f.last_drop
    # a later message with its transforms in the buffer is released at once
    _publish_odom(rt, 0.3, 3.0)
    _publish_odom(rt, 0.4, 4.0)
    rt.scheduler.run_until(0.3)
    node.filter.add(_msg(0.35))
    assert node.placed == [(0.3, 0.35, pytest.approx(3.5))]


def test_queue_is_bounded_and_releases_in_arrival_order() -> None:
    rt, node = _rig(queue_size=2)
    for stamp in (0.1, 0.2, 0.3):
        node.filter.add(_msg(stamp))
    f = node.filter
    assert [m.header.stamp for m in f.pending] == [0.2, 0.3]
    assert f.dropped_queue_full == 1 and f.dropped_timeout == 0
    assert f.last_drop == "scan at t=0.100 dropped: the queue of 2 waiting for TF is full"
    _publish_odom(rt, 0.0, 0.0)
    _publish_odom(rt, 0.4, 4.0)
    rt.scheduler.run_until(0.1)
    assert [(s, x) for _, s, x in node.placed] == [(0.2, pytest.approx(2.0)),
                                                   (0.3, pytest.approx(3.0))]
    assert f.released == 2 and f.pending == ()


def test_no_retry_while_the_node_is_inactive_and_clear_forgets() -> None:
    rt, node = _rig()
    node.filter.add(_msg(0.05))
    node.deactivate()
    _publish_odom(rt, 0.0, 0.0)
    _publish_odom(rt, 0.1, 1.0)
    rt.scheduler.run_until(0.2)
    assert node.placed == [] and len(node.filter.pending) == 1
    node.filter.clear()
    node.activate()
    rt.scheduler.run_until(0.4)
    assert node.placed == [] and node.filter.pending == () and node.filter.dropped == 0


@pytest.mark.parametrize(("option", "value", "rule"), [("queue_size", 0, ">= 1"),
                                                       ("timeout", -0.1, ">= 0 s")])
def test_bad_options_are_refused_with_the_key(option: str, value: float, rule: str) -> None:
    with pytest.raises(ConfigError, match=rf"listener\.{option}: the TF message filter's "
                                          rf"{option} must be {rule}, got {value}"):
        Listener(Runtime(), **{option: value})

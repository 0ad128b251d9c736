"""The shared e-stop latch and its lock topic (/emergency_stop, std_msgs/Bool, true = stop):
a true from anyone latches, a false from anyone but an authorised operator is refused and
the lock is re-asserted at the same instant, the base holds zero throughout."""

from __future__ import annotations

from navstack.core.msgs import Bool, Twist, Vector3
from navstack.interfaces.estop import LOCK_TOPIC, EStopGate
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime


def _cmd(vx: float) -> Twist:
    return Twist(Vector3(vx, 0.0, 0.0), Vector3())


def test_lock_topic_true_latches_false_is_refused_until_authorised_release() -> None:
    rt = Runtime()
    base: list[tuple[float, float]] = []
    lock: list[tuple[float, bool]] = []
    rt.bus.subscribe("/cmd_vel", Twist, lambda m: base.append((rt.now, m.linear.x)),
                     QoS(depth=10))
    gate = EStopGate(rt, heartbeat=0.1)
    rt.bus.subscribe(LOCK_TOPIC, Bool, lambda m: lock.append((rt.now, m.data)), QoS(depth=10))
    nav = rt.bus.publisher("/cmd_vel", Twist)
    switch = rt.bus.publisher(LOCK_TOPIC, Bool)  # a hardware e-stop switch
    rt.scheduler.create_timer(0.05, lambda: nav.publish(_cmd(0.5)), first_at=0.0)
    rt.scheduler.call_at(0.2, lambda: switch.publish(Bool(True)))
    rt.scheduler.call_at(0.5, lambda: switch.publish(Bool(False)))  # unauthorised release
    rt.scheduler.run_until(1.0)
    assert gate.latched and gate.latched_at == 0.2
    assert gate.source == f"lock topic {LOCK_TOPIC}"
    assert gate.refused_releases == 1
    held = {}
    for t, vx in base:
        held[t] = vx  # the command the base holds at each instant
    assert all(v == 0.5 for t, v in held.items() if t < 0.2 - 1e-9)
    assert all(v == 0.0 for t, v in held.items() if t >= 0.2 - 1e-9)
    # the lock topic: after the foreign false at 0.5 the latch re-asserts true at 0.5
    at_half = [v for t, v in lock if abs(t - 0.5) < 1e-9]
    assert at_half[-1] is True and False in at_half
    # the heartbeat keeps re-sending the state (a mux lock with a timeout stays fed)
    assert {round(t, 2) for t, v in lock if v} >= {0.3, 0.4, 0.6, 0.7, 0.8, 0.9}
    kinds = [(e.kind, e.source) for e in gate.events]
    assert kinds == [("latch", f"lock topic {LOCK_TOPIC}"),
                     ("refused_release", f"lock topic {LOCK_TOPIC}")]
    # an authorised operator releases; commands pass again
    rt.scheduler.call_at(1.0, lambda: gate.release("web"))
    rt.scheduler.run_until(1.3)
    assert not gate.latched and base[-1][1] == 0.5
    assert lock[-1][1] is False
    assert gate.history()[-1]["kind"] == "release" and gate.history()[-1]["source"] == "web"

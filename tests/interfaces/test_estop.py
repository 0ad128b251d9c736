"""The live stack's e-stop hub on the twist_mux lock (docs/command_path.md): every authority
latches the one lock, the authority that latched releases, a raw latch on the lock topic
is released only there; the base holds zero while latched, refusals are recorded."""

from __future__ import annotations

import pytest

from navstack.core.msgs import Bool, Twist, Vector3
from navstack.interfaces.estop import LOCK_TOPIC, EStopGate, EStopReleaseRefused
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime


def _cmd(vx: float) -> Twist:
    return Twist(Vector3(vx, 0.0, 0.0), Vector3())


def _held(base: list[tuple[float, float]]) -> dict[float, float]:
    held: dict[float, float] = {}
    for t, vx in base:
        held[round(t, 6)] = vx  # the command the base holds after each instant
    return held


def test_raw_lock_latch_holds_until_released_on_the_lock_topic() -> None:
    rt = Runtime()
    base: list[tuple[float, float]] = []
    rt.bus.subscribe("/cmd_vel", Twist, lambda m: base.append((rt.now, m.linear.x)),
                     QoS(depth=10))
    gate = EStopGate(rt)
    nav = rt.bus.publisher("/cmd_vel", Twist)
    switch = rt.bus.publisher(LOCK_TOPIC, Bool)  # a hardware e-stop switch
    rt.scheduler.create_timer(0.05, lambda: nav.publish(_cmd(0.5)), first_at=0.0)
    rt.scheduler.call_at(0.2, lambda: switch.publish(Bool(True)))
    rt.scheduler.run_until(0.5)
    assert gate.latched and gate.latched_at == 0.2 and gate.holder == ""
    with pytest.raises(EStopReleaseRefused, match=r"^the e-stop is latched by a publisher "
                       r"on /emergency_stop, not by 'web'; release it with false on "
                       r"/emergency_stop$"):
        gate.release("web")
    assert gate.latched and gate.refused_releases == 1
    rt.scheduler.call_at(0.7, lambda: switch.publish(Bool(False)))
    rt.scheduler.run_until(1.0)
    assert not gate.latched and gate.released_at == 0.7
    held = _held(base)
    assert all(v == 0.5 for t, v in held.items() if t < 0.2)
    assert all(v == 0.0 for t, v in held.items() if 0.2 <= t < 0.7)
    assert held[0.75] == 0.5  # commands pass again after the release
    assert [(e["kind"], e["source"]) for e in gate.history()] == [
        ("latch", "lock topic /emergency_stop"), ("refused_release", "web"),
        ("release", "lock topic /emergency_stop")]


def test_the_authority_that_latched_releases() -> None:
    rt = Runtime()
    gate = EStopGate(rt)
    lock: list[bool] = []
    rt.bus.subscribe(LOCK_TOPIC, Bool, lambda m: lock.append(m.data), QoS(depth=10))
    rt.scheduler.call_at(0.1, lambda: gate.latch("chat said 1", "telegram:42", 0.08))
    rt.scheduler.run_until(0.2)
    assert gate.latched and gate.holder == "telegram:42" and gate.reason == "chat said 1"
    for other in ("web", "telegram:43", "phone"):
        with pytest.raises(EStopReleaseRefused, match="held by 'telegram:42'"):
            gate.release(other)
    assert gate.latch("web too", "web") == 0.1  # idempotent: the first latch time stays
    assert gate.holder == "web"  # the last latch holds the authority
    with pytest.raises(EStopReleaseRefused):
        gate.release("telegram:42")
    assert gate.release("web") == 0.2
    rt.scheduler.run_until(0.3)
    assert not gate.latched and lock == [True, True, False]
    events = gate.history()
    assert events[0] == {"kind": "latch", "source": "telegram:42", "time": 0.1,
                         "reason": "chat said 1", "requested_at": 0.08}
    assert [e["kind"] for e in events] == ["latch"] + ["refused_release"] * 4 + ["release"]
    assert gate.refused_releases == 4

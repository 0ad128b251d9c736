"""Scheduler ordering and determinism; bus QoS (keep_last), latching, services."""

import pytest

from navstack.core.errors import BusError, UnknownNameError
from navstack.core.msgs import Float64, String
from navstack.runtime.bus import Bus, QoS
from navstack.runtime.scheduler import Scheduler


def test_events_run_in_time_then_insertion_order() -> None:
    s = Scheduler()
    order: list[str] = []
    s.call_at(2.0, order.append, "c")
    s.call_at(1.0, order.append, "a")
    s.call_at(1.0, order.append, "b")
    s.run_until(5.0)
    assert order == ["a", "b", "c"]
    assert s.now == 5.0


def test_timer_has_no_drift_and_cancel_stops_it() -> None:
    s = Scheduler()
    times: list[float] = []
    timer = s.create_timer(0.1, lambda: times.append(s.now))
    s.run_until(1.0)
    assert len(times) == 10
    assert times[-1] == pytest.approx(1.0, abs=1e-12)
    assert times[6] == 0.1 * 7  # start + k*period, not accumulated sums
    timer.cancel()
    s.run_until(2.0)
    assert len(times) == 10


def test_run_until_stops_on_condition() -> None:
    s = Scheduler()
    count = [0]
    s.create_timer(0.5, lambda: count.__setitem__(0, count[0] + 1))
    reached = s.run_until(100.0, until=lambda: count[0] >= 3)
    assert reached and count[0] == 3 and s.now == 1.5


def test_wall_mode_follows_wall_clock() -> None:
    import time

    s = Scheduler(mode="wall")
    fired: list[float] = []
    s.call_later(0.05, lambda: fired.append(time.monotonic()))
    t0 = time.monotonic()
    s.run_for(0.06)
    assert fired and fired[0] - t0 >= 0.045


def test_keep_last_drops_oldest_when_subscriber_lags() -> None:
    s = Scheduler()
    bus = Bus(s)
    got: list[float] = []
    sub = bus.subscribe("/x", Float64, lambda m: got.append(m.data), QoS(depth=3))
    pub = bus.publisher("/x", Float64)
    for i in range(5):  # all published before the loop delivers anything
        pub.publish(Float64(float(i)))
    s.run_until(0.0)
    assert got == [2.0, 3.0, 4.0]
    assert sub.dropped == 2


def test_latched_topic_reaches_late_subscriber() -> None:
    s = Scheduler()
    bus = Bus(s)
    pub = bus.publisher("/map_name", String, QoS(depth=1, latched=True))
    pub.publish(String("first"))
    pub.publish(String("office"))
    s.run_until(1.0)
    got: list[str] = []
    bus.subscribe("/map_name", String, lambda m: got.append(m.data))
    s.run_until(2.0)
    assert got == ["office"]
    # a volatile topic gives late joiners nothing
    vol = bus.publisher("/chatter", String)
    vol.publish(String("lost"))
    s.run_until(3.0)
    late: list[str] = []
    bus.subscribe("/chatter", String, lambda m: late.append(m.data))
    s.run_until(4.0)
    assert late == []


def test_delivery_is_not_reentrant() -> None:
    s = Scheduler()
    bus = Bus(s)
    log: list[str] = []
    pub_b = bus.publisher("/b", String)

    def on_a(m: String) -> None:
        log.append("a:" + m.data)
        pub_b.publish(String(m.data))
        log.append("a-done")

    bus.subscribe("/a", String, on_a)
    bus.subscribe("/b", String, lambda m: log.append("b:" + m.data))
    bus.publisher("/a", String).publish(String("1"))
    s.run_until(0.0)
    assert log == ["a:1", "a-done", "b:1"]


def test_topic_type_is_enforced() -> None:
    bus = Bus(Scheduler())
    bus.publisher("/t", String)
    with pytest.raises(BusError, match="already carries String; cannot use it for Float64"):
        bus.publisher("/t", Float64)
    pub = bus.publisher("/t", String)
    with pytest.raises(BusError, match="topic '/t' carries String, not Float64"):
        pub.publish(Float64(1.0))  # type: ignore[arg-type]


def test_services() -> None:
    bus = Bus(Scheduler())
    bus.advertise_service("/add_one", lambda x: x + 1)
    assert bus.call("/add_one", 41) == 42
    with pytest.raises(UnknownNameError, match="unknown service '/add_on'"):
        bus.call("/add_on", 1)
    with pytest.raises(BusError, match="already advertised"):
        bus.advertise_service("/add_one", lambda x: x)


def _tie_trace(start: float) -> list[tuple[float, str]]:
    s = Scheduler(start_time=start)
    order: list[tuple[float, str]] = []
    for name, period in (("odom", 0.02), ("scan", 0.1), ("control", 0.05)):
        s.create_timer(period, lambda n=name: order.append((s.elapsed, n)))
    s.run_for(30.0)
    s.call_later(0.1, lambda: order.append((s.elapsed, "later")))
    s.run_for(0.1)
    return order


@pytest.mark.parametrize("start", [1000.0, 1002.0, 1030.3, 1_767_225_600.0])
def test_timer_ties_run_as_from_zero_at_any_start_value(start: float) -> None:
    # a 50 Hz, a 10 Hz and a 20 Hz timer coincide every 0.1 s; as absolute float sums
    # start + k * period they tied or not depending on the start value's rounding
    ref = _tie_trace(0.0)
    assert len(ref) == 1500 + 300 + 600 + 5 + 1 + 3
    assert _tie_trace(start) == ref  # same elapsed times, same order, to the bit

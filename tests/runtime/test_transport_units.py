"""Pure parts of the transports: NTP arithmetic and clock filter, the JSON envelope,
stamp shifting, impairments, rmw_zenoh liveliness keys, and the scheduler's thread entry."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from navstack.core.errors import BusError, ConfigError
from navstack.core.msgs import Header, Path, PoseStamped, TFMessage, TransformStamped
from navstack.navigation.messages import FollowPathGoal
from navstack.runtime.actions import ActionResult, GoalStatus
from navstack.runtime.scheduler import Scheduler
from navstack.runtime.transports.clock_sync import OffsetEstimator, exchange_sample
from navstack.runtime.transports.impairments import ImpairedLink, LinkImpairments
from navstack.runtime.transports.keys import liveliness_token, namespaced
from navstack.runtime.transports.payloads import decode_envelope, encode_envelope, shift_stamps


def test_exchange_gives_offset_and_round_trip() -> None:
    # server 2.0 s ahead, 10 ms each way, 1 ms in the server
    s = exchange_sample(t1=100.0, t2=102.010, t3=102.011, t4=100.021)
    assert s.offset == pytest.approx(2.0)
    assert s.delay == pytest.approx(0.020)


def test_asymmetric_delay_biases_by_at_most_half_the_round_trip() -> None:
    s = exchange_sample(t1=0.0, t2=30.050, t3=30.050, t4=0.060)  # 50 ms out, 10 ms back
    assert abs(s.offset - 30.0) <= s.delay / 2 + 1e-12


def test_estimator_keeps_the_minimum_delay_sample_and_forgets_old_ones() -> None:
    est = OffsetEstimator(window=8, max_age=10.0)
    assert not est.ready and est.offset == 0.0
    est.add(exchange_sample(0.0, 1.3, 1.3, 0.2))     # queued: 0.2 s round trip
    est.add(exchange_sample(1.0, 2.0005, 2.0005, 1.001))  # clean: 1 ms
    est.add(exchange_sample(2.0, 3.2, 3.2, 2.3))
    assert est.offset == pytest.approx(1.0, abs=1e-9)
    assert est.delay == pytest.approx(0.001)
    est.add(exchange_sample(20.0, 25.0, 25.0, 20.002))  # clock stepped; old ones too old
    assert est.offset == pytest.approx(4.999, abs=1e-9)


def test_non_finite_stamps_are_refused() -> None:
    with pytest.raises(ValueError, match="t3 is not finite"):
        exchange_sample(0.0, 1.0, float("nan"), 2.0)


def test_envelope_round_trips_goals_and_results() -> None:
    path = Path.from_array(np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.2]]), "map", 3.5)
    goal = FollowPathGoal(path, "FollowPath", "")
    back = decode_envelope(encode_envelope({"gid": "base-1", "goal": goal}))
    assert back["gid"] == "base-1"
    np.testing.assert_array_equal(back["goal"].path.as_array(), path.as_array())
    assert back["goal"].path.header == path.header
    result = ActionResult(GoalStatus.FAILED, 105, "no progress", (1, 2.5))
    assert decode_envelope(encode_envelope(result)) == result


def test_envelope_refuses_types_outside_the_message_modules() -> None:
    evil = b'{"@t":"subprocess:Popen","args":["true"]}'
    with pytest.raises(BusError, match="outside the message modules"):
        decode_envelope(evil)
    with pytest.raises(BusError, match="not a message dataclass"):
        decode_envelope(b'{"@t":"navstack.navigation.controller_server:ControllerServer"}')
    with pytest.raises(BusError, match="malformed envelope"):
        decode_envelope(b"{not json")


def test_shift_stamps_moves_every_header() -> None:
    tf = TFMessage((TransformStamped(Header(10.0, "map"), "odom"),
                    TransformStamped(Header(11.0, "odom"), "base_link")))
    moved = shift_stamps(tf, -2.5)
    assert [t.header.stamp for t in moved.transforms] == [7.5, 8.5]
    goal = FollowPathGoal(Path(Header(5.0, "map"), (PoseStamped(Header(5.0, "map")),)))
    g2 = shift_stamps(goal, 1.0)
    assert g2.path.header.stamp == 6.0 and g2.path.poses[0].header.stamp == 6.0
    assert shift_stamps(goal, 0.0) is goal


def test_lazy_path_crosses_the_transport() -> None:
    """A Path made from an array builds its poses only when read; its fields (``_poses``
    None, ``_xyt``) must survive the envelope and a stamp shift."""
    xyt = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.3]])
    lazy = Path.from_array(xyt, "map", 4.0)
    back = decode_envelope(encode_envelope(FollowPathGoal(lazy))).path
    assert np.array_equal(back.as_array(), xyt) and back.header.stamp == 4.0
    assert [round(p.pose.position.y, 9) for p in back.poses] == [0.0, 0.5]
    moved = shift_stamps(FollowPathGoal(Path.from_array(xyt, "map", 4.0)), 1.0).path
    assert moved.header.stamp == 5.0 and np.array_equal(moved.as_array(), xyt)
    with pytest.raises(ValueError, match="_xyt"):
        Path(Header(), _poses=None)


def test_blackouts_and_loss() -> None:
    link = ImpairedLink(LinkImpairments(blackouts=[(5.0, 2.0)], loss=0.25, seed=3))
    assert link.in_blackout(5.0) and link.in_blackout(6.99) and not link.in_blackout(7.0)
    assert not link.passes(6.0)
    passed = sum(link.passes(10.0 + i * 1e-3) for i in range(4000))
    assert 2800 < passed < 3200  # ~75 %
    assert link.dropped_blackout == 1 and link.dropped_loss == 4000 - passed
    with pytest.raises(ConfigError, match="duration > 0"):
        LinkImpairments.from_mapping({"blackouts": [[1.0, 0.0]]}, file="s.yaml",
                                     key_path="transport.robot.impairments")


def test_liveliness_tokens_follow_rmw_zenoh() -> None:
    tok = liveliness_token(0, "abc", 0, 5, "MP", "/robot1", "robot1", "/robot1/scan",
                           "sensor_msgs/msg/LaserScan", "1:2:1,5")
    parts = tok.split("/")
    assert parts[:9] == ["@ros2_lv", "0", "abc", "0", "5", "MP", "%", "%robot1", "robot1"]
    assert parts[9] == "%robot1%scan" and parts[10] == "sensor_msgs::msg::dds_::LaserScan_"
    assert parts[11].startswith("RIHS01_") and parts[12] == "1:2:1,5"
    assert namespaced("/robot1", "scan") == "/robot1/scan" and namespaced("", "/a") == "/a"
    with pytest.raises(ConfigError, match="not a valid ROS name"):
        namespaced("", "/a//b")


def test_wall_clock_rate_and_offset() -> None:
    s = Scheduler("wall", rate=4.0, clock_offset=30.0, epoch=time.time() - 10.0)

    def expected(wall: float) -> float:
        return 30.0 + s.epoch + 4.0 * (wall - s.epoch)

    before = time.time()
    reading = s.clock()
    after = time.time()
    # bracketed by the system clock read on either side: no timing tolerance to flake
    assert expected(before) <= reading <= expected(after)
    with pytest.raises(ValueError, match="clock rate must be a positive"):
        Scheduler("wall", rate=0.0)


def test_post_from_another_thread_wakes_a_waiting_wall_loop() -> None:
    s = Scheduler("wall")
    ran: list[float] = []
    s.call_later(5.0, lambda: None)  # the loop would otherwise sleep 5 s
    t0 = time.monotonic()
    threading.Timer(0.1, s.post, (lambda: (ran.append(time.monotonic() - t0), s.stop()),)).start()
    s.run_for(5.0)
    assert ran and ran[0] < 2.5  # woken by the post, long before the 5 s sleep ended


def test_post_at_runs_at_the_senders_time_and_counts_late_arrivals() -> None:
    s = Scheduler("sim", start_time=10.0)
    ran: list[tuple[str, float]] = []
    s.create_timer(0.1, lambda: ran.append(("timer", s.now)))
    s.post_at(10.25, lambda: ran.append(("posted", s.now)))
    s.run_until(10.31)
    assert [(what, round(t, 9)) for what, t in ran] == [
        ("timer", 10.1), ("timer", 10.2), ("posted", 10.25), ("timer", 10.3)]
    assert s.late_posts == 0
    s.post_at(10.2, lambda: ran.append(("late", s.now)))  # the loop is past 10.2 already
    s.run_until(10.35)
    assert ran[-1] == ("late", 10.31) and s.late_posts == 1


def test_horizon_stops_the_loop_and_run_until_never_passes_it() -> None:
    s = Scheduler("sim", start_time=0.0)
    blocked: list[float] = []
    ran: list[float] = []
    s.create_timer(0.1, lambda: ran.append(s.now))
    s.horizon = lambda: 0.25

    def on_blocked() -> None:  # the peer answers once: the horizon moves to 0.45
        blocked.append(s.now)
        s.horizon = lambda: 0.45
        s.on_blocked = None

    s.on_blocked = on_blocked
    s.run_until(2.0, until=lambda: bool(ran) and ran[-1] >= 0.35)
    assert blocked == [0.2]  # waited at the horizon 0.25 with the next event at 0.3
    assert [round(t, 6) for t in ran] == [0.1, 0.2, 0.3, 0.4]
    s.run_until(0.48)  # nothing is due before 0.48: time runs out, but at the horizon
    assert s.now == 0.45


def test_idle_until_moves_the_clock_only_past_no_pending_work() -> None:
    s = Scheduler("sim", start_time=0.0)
    s.call_at(0.5, lambda: None)
    s.idle_until(0.7)
    assert s.now == 0.0  # an event at 0.5 is still due
    s.idle_until(0.4)
    assert s.now == 0.4

"""twist_mux arbitration, table-driven on the rover's configuration loaded verbatim."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import pytest

from navstack.control.twist_mux import MuxAction, TwistMux, TwistMuxParams, twist_mux_params
from navstack.core.errors import ConfigError
from navstack.runtime.config import load_yaml

ROVER = Path(str(resources.files("navstack") / "config" / "rover_twist_mux.yaml"))
F, N, Z = MuxAction.FORWARD, MuxAction.NONE, MuxAction.ZERO


def rover() -> TwistMuxParams:
    return twist_mux_params(load_yaml(ROVER), file=str(ROVER))


def test_rover_config_loads_verbatim_with_the_filled_in_timeouts() -> None:
    p = rover()
    assert [(e.name, e.topic, e.priority, e.timeout) for e in p.topics] == [
        ("navigation", "/nav_vel1", 50, 0.5), ("joystick", "/joystick/twist", 100, 0.5),
        ("rqt", "/rqt_vel", 90, 0.5), ("hand_drive", "/cmd_hand_drive", 100, 0.5),
        ("lora", "/lora/rover/received/twist", 120, 5.0), ("e_stop", "/stop", 255, 0.5)]
    assert [(e.name, e.topic, e.priority, e.timeout) for e in p.locks] == [
        ("e_stop_lock", "/emergency_stop", 255, 0.0)]


# (events, expected action of the last event, expected winner after it); an event is
# (time, "in" | "lock" | "tick", name, value)
CASES: dict[str, tuple[list[tuple[float, str, str, bool]], MuxAction, str | None]] = {
    "navigation alone is forwarded": ([(1.0, "in", "navigation", True)], F, "navigation"),
    "joystick beats navigation": (
        [(1.0, "in", "navigation", True), (1.1, "in", "joystick", True),
         (1.2, "in", "navigation", True)], N, "joystick"),
    "joystick forwarded over navigation": (
        [(1.0, "in", "navigation", True), (1.1, "in", "joystick", True)], F, "joystick"),
    "joystick timed out after 0.5 s: navigation again": (
        [(1.0, "in", "joystick", True), (1.6, "in", "navigation", True)], F, "navigation"),
    "exactly 0.5 s is not a timeout": (
        [(1.0, "in", "joystick", True), (1.5, "in", "navigation", True)], N, "joystick"),
    "tie at 100: joystick (first in the file) beats hand drive": (
        [(1.0, "in", "joystick", True), (1.1, "in", "hand_drive", True)], N, "joystick"),
    "tie at 100: hand drive alone is forwarded": (
        [(1.0, "in", "hand_drive", True)], F, "hand_drive"),
    "tie at 100: hand drive after joystick went silent": (
        [(1.0, "in", "joystick", True), (1.4, "in", "hand_drive", True),
         (1.6, "in", "hand_drive", True)], F, "hand_drive"),
    "rqt 90 beats navigation 50": (
        [(1.0, "in", "rqt", True), (1.1, "in", "navigation", True)], N, "rqt"),
    "joystick 100 beats rqt 90": (
        [(1.0, "in", "rqt", True), (1.1, "in", "joystick", True)], F, "joystick"),
    "LoRa 120 holds 5 s": (
        [(1.0, "in", "lora", True), (5.9, "in", "joystick", True)], N, "lora"),
    "LoRa timed out after 5 s": (
        [(1.0, "in", "lora", True), (6.1, "in", "joystick", True)], F, "joystick"),
    "e_stop 255 beats LoRa": (
        [(1.0, "in", "e_stop", True), (1.1, "in", "lora", True)], N, "e_stop"),
    "lock masks navigation: zero instead": (
        [(1.0, "lock", "e_stop_lock", True), (1.1, "in", "navigation", True)], Z, None),
    "lock masks LoRa 120: zero instead": (
        [(1.0, "lock", "e_stop_lock", True), (1.1, "in", "lora", True)], Z, None),
    "lock 255 does not mask e_stop 255": (
        [(1.0, "lock", "e_stop_lock", True), (1.1, "in", "e_stop", True)], F, "e_stop"),
    "lock engaging over navigation publishes zero": (
        [(1.0, "in", "navigation", True), (1.05, "lock", "e_stop_lock", True)], Z, None),
    "lock with nothing running still publishes zero": (
        [(1.0, "lock", "e_stop_lock", True)], Z, None),
    "released lock: navigation passes again": (
        [(1.0, "lock", "e_stop_lock", True), (2.0, "lock", "e_stop_lock", False),
         (2.1, "in", "navigation", True)], F, "navigation"),
    "a false lock never engages": (
        [(1.0, "lock", "e_stop_lock", False), (1.1, "in", "navigation", True)], F,
        "navigation"),
    "lock timeout 0.0 never expires": (
        [(1.0, "lock", "e_stop_lock", False), (100.0, "in", "navigation", True)], F,
        "navigation"),
    "nothing published: no winner": ([(10.0, "tick", "", True)], N, None),
    "winner timed out: one zero": (
        [(1.0, "in", "navigation", True), (1.6, "tick", "", True)], Z, None),
    "winner timed out: only one zero": (
        [(1.0, "in", "navigation", True), (1.6, "tick", "", True), (1.7, "tick", "", True)],
        N, None),
    "joystick timed out, navigation still live: no zero": (
        [(1.0, "in", "navigation", True), (1.1, "in", "joystick", True),
         (1.2, "in", "navigation", True), (1.65, "tick", "", True)], N, "navigation"),
}


def _play(mux: TwistMux, events: list[tuple[float, str, str, bool]]) -> MuxAction:
    action = MuxAction.NONE
    for t, kind, name, value in events:
        if kind == "in":
            action = mux.on_input(name, t)
        elif kind == "lock":
            action = mux.on_lock(name, value, t)
        else:
            action = mux.tick(t)
    return action


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_rover_arbitration_table(case: str) -> None:
    events, action, winner = CASES[case]
    mux = TwistMux(rover())
    assert _play(mux, events) is action
    assert mux.winner(events[-1][0]) == winner


DEADMAN = {"topics": [{"name": "navigation", "topic": "/nav_vel", "timeout": 0.5,
                       "priority": 10}],
           "locks": [{"name": "heartbeat", "topic": "/heartbeat", "timeout": 0.5,
                      "priority": 100}]}


@pytest.mark.parametrize(("events", "action", "locked"), [
    ([(0.1, "in", "navigation", True)], Z, True),  # a lock that never published is locked
    ([(0.1, "lock", "heartbeat", False), (0.2, "in", "navigation", True)], F, False),
    ([(0.1, "lock", "heartbeat", False), (0.2, "in", "navigation", True),
      (0.65, "tick", "", True)], Z, True),  # the heartbeat died: locked, zero at once
    ([(0.1, "lock", "heartbeat", False), (0.2, "in", "navigation", True),
      (0.65, "tick", "", True), (0.7, "in", "navigation", True)], Z, True),
    ([(0.1, "lock", "heartbeat", False), (0.65, "tick", "", True),
      (0.7, "lock", "heartbeat", False), (0.75, "in", "navigation", True)], F, False),
], ids=["never published", "alive", "dead publisher", "zero while dead", "alive again"])
def test_dead_lock_publisher_locks(events: list[tuple[float, str, str, bool]],
                                   action: MuxAction, locked: bool) -> None:
    mux = TwistMux(twist_mux_params(DEADMAN))
    assert _play(mux, events) is action
    assert bool(mux.active_locks(events[-1][0])) is locked


def test_ros2_layout_and_departures_can_be_switched_off() -> None:
    data = {"twist_mux": {"ros__parameters": {
        "topics": {"navigation": {"topic": "/nav_vel", "timeout": 0.5, "priority": 10},
                   "joystick": {"topic": "/joy_vel", "timeout": 0.5, "priority": 100}},
        "locks": {"pause": {"topic": "/pause", "timeout": 0.0, "priority": 100}},
        "zero_when_locked": False, "zero_on_timeout": False}}}
    p = twist_mux_params(data)
    assert [e.name for e in p.topics] == ["navigation", "joystick"]
    mux = TwistMux(p)  # twist_mux's own behaviour: drop, never zero
    assert mux.on_input("navigation", 1.0) is F
    assert mux.on_lock("pause", True, 1.1) is N
    assert mux.on_input("navigation", 1.2) is N
    assert mux.on_input("joystick", 1.3) is F  # priority 100 is not below the lock's 100
    assert mux.tick(2.0) is N


@pytest.mark.parametrize(("data", "message"), [
    ({"topics": [{"name": "a", "topic": "/a", "priority": 10}]},
     r"topics\[0\]\.timeout: required key is missing"),
    ({"topics": [{"name": "a", "topic": "/a", "timeout": 0.5, "priority": 300}]},
     r"topics\[0\]\.priority: Input should be less than or equal to 255"),
    ({"topics": [{"name": "a", "topic": "/a", "timeout": -1.0, "priority": 1}]},
     r"topics\[0\]\.timeout: Input should be greater than or equal to 0"),
    ({"topics": [{"name": "a", "topic": "/a", "timeout": 0.5, "priority": 1},
                 {"name": "a", "topic": "/b", "timeout": 0.5, "priority": 2}]},
     r"topics: duplicate topic name 'a'"),
    ({"topics": [{"name": "a", "topic": "/a", "timeout": 0.5, "priority": 1}],
      "locks": [{"name": "l", "topic": "/a", "timeout": 0.0, "priority": 2}]},
     r"topic '/a' is used by more than one entry"),
    ({"topics": "nav"}, r"topics: must be a list of topic entries"),
    ({"topics": []}, r"topics: List should have at least 1 item"),
    ({"topics": [{"name": "a", "topic": "/a", "timeout": 0.5, "priority": 1}],
      "lock": []}, r"lock: unknown key \(did you mean 'locks'\?\)"),
])
def test_bad_configurations_name_the_key(data: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        twist_mux_params(data, file="mux.yaml")

"""TwistMuxNode and EStopClient on a bare bus: exact command sequences at the base."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import pytest

from navstack.control.twist_mux import twist_mux_params
from navstack.core.msgs import Bool, Header, String, Twist, TwistStamped, Vector3
from navstack.nodes.estop import EStopClient, EStopReleaseRefused
from navstack.nodes.twist_mux import TwistMuxNode
from navstack.runtime.bus import QoS
from navstack.runtime.config import load_yaml
from navstack.runtime.node import Runtime

ROVER = Path(str(resources.files("navstack") / "config" / "rover_twist_mux.yaml"))


def _cmd(vx: float, wz: float = 0.0) -> Twist:
    return Twist(Vector3(vx, 0.0, 0.0), Vector3(0.0, 0.0, wz))


class Rig:
    """The rover's mux with a base recording (t, vx) and publishers for its inputs."""

    def __init__(self, stamped: bool = False) -> None:
        self.rt = Runtime()
        params = twist_mux_params(load_yaml(ROVER), overrides={"use_stamped": stamped})
        self.mux = TwistMuxNode(self.rt, params)
        self.rt.bring_up()
        self.seen: list[tuple[float, float]] = []
        kind = TwistStamped if stamped else Twist
        self.rt.bus.subscribe("/cmd_vel", kind, self._on_base, QoS(depth=1))

    def _on_base(self, m: Twist | TwistStamped) -> None:
        t = m.twist if isinstance(m, TwistStamped) else m
        self.seen.append((self.rt.now, t.linear.x))

    def at(self, t: float, fn: object) -> None:
        self.rt.scheduler.call_at(t, fn)  # type: ignore[arg-type]

    def last_by_time(self) -> dict[float, float]:
        out: dict[float, float] = {}
        for t, vx in self.seen:
            out[round(t, 6)] = vx
        return out


def test_estop_lock_zeroes_the_base_at_once_and_until_the_same_authority_releases() -> None:
    r = Rig()
    nav = r.rt.bus.publisher("/nav_vel1", Twist)
    joy = r.rt.bus.publisher("/joystick/twist", Twist)
    web = EStopClient(r.rt, "web")
    telegram = EStopClient(r.rt, "telegram:42")
    for k in range(1, 40):  # navigation at 20 Hz from 0.05 s to 1.95 s
        r.at(0.05 * k, lambda k=k: nav.publish(_cmd(0.4)))
    r.at(0.52, lambda: joy.publish(_cmd(-0.2)))
    r.rt.scheduler.run_until(0.50)
    assert r.last_by_time()[0.5] == 0.4
    latched_at = web.latch("test")
    assert latched_at == 0.5
    r.rt.scheduler.run_until(1.0)
    last = r.last_by_time()
    assert last[0.5] == 0.0  # the same instant: the base's last command at 0.5 s is zero
    assert all(vx == 0.0 for t, vx in r.seen if t > 0.5)
    assert r.mux.locked and telegram.latched and telegram.holder == "web"
    with pytest.raises(EStopReleaseRefused, match=r"^the e-stop is held by 'web', not by "
                                                  r"'telegram:42'; release it there$"):
        telegram.release()
    r.rt.scheduler.run_until(1.2)
    assert r.mux.locked and all(vx == 0.0 for t, vx in r.seen if t > 0.5)
    assert web.release() == 1.2
    r.rt.scheduler.run_until(1.3)
    assert not telegram.latched and telegram.released_at == 1.2
    assert r.last_by_time()[1.25] == 0.4  # navigation passes again
    zeros = sum(1 for t, vx in r.seen if 0.5 <= t <= 1.2 and vx == 0.0)
    assert zeros == 1 + 13 + 1  # the latch, then one per masked message (navigation, joystick)
    assert r.mux.mux_state()["locked_by"] == []


def test_raw_lock_publisher_is_released_only_on_the_topic() -> None:
    r = Rig()
    web = EStopClient(r.rt, "web")
    raw = r.rt.bus.publisher("/emergency_stop", Bool)
    raw.publish(Bool(True))
    r.rt.scheduler.run_until(0.1)
    assert web.latched and web.holder == "" and r.mux.locked
    assert r.seen == [(0.0, 0.0)]
    with pytest.raises(EStopReleaseRefused,
                       match=r"latched by a publisher on /emergency_stop, not by 'web'; "
                             r"release it with false on /emergency_stop"):
        web.release()
    raw.publish(Bool(False))
    r.rt.scheduler.run_until(0.2)
    assert not web.latched and not r.mux.locked
    # a later joiner sees the source of the last value: released, no holder
    late: list[str] = []
    r.rt.bus.subscribe("/emergency_stop/source", String, lambda m: late.append(m.data))
    r.rt.scheduler.run_until(0.3)
    assert late == [] or late[-1] == ""


def test_last_latch_holds_the_authority_and_stop_input_passes_under_the_lock() -> None:
    r = Rig()
    web, phone = EStopClient(r.rt, "web"), EStopClient(r.rt, "phone")
    stop = r.rt.bus.publisher("/stop", Twist)
    web.latch()
    r.rt.scheduler.run_until(0.1)
    phone.latch()
    r.rt.scheduler.run_until(0.2)
    assert web.holder == "phone" and web.latched_at == 0.0
    with pytest.raises(EStopReleaseRefused, match="held by 'phone'"):
        web.release()
    stop.publish(_cmd(0.0, 0.3))  # e_stop 255 is not masked by the 255 lock
    r.rt.scheduler.run_until(0.3)
    assert r.mux.mux_state()["active"] == "e_stop" and r.mux.forwarded == 1
    phone.release()
    r.rt.scheduler.run_until(0.4)
    assert not web.latched
    with pytest.raises(ValueError, match="needs an authority"):
        EStopClient(r.rt, " ")


def test_stamped_inputs_and_output() -> None:
    r = Rig(stamped=True)
    nav = r.rt.bus.publisher("/nav_vel1", TwistStamped)
    nav.publish(TwistStamped(Header(0.0, "base_link"), _cmd(0.3)))
    r.rt.scheduler.run_until(0.1)
    EStopClient(r.rt, "joystick").latch()
    r.rt.scheduler.run_until(0.2)
    assert r.seen == [(0.0, 0.3), (0.1, 0.0)]
    locked: list[bool] = []
    r.rt.bus.subscribe("/twist_mux/locked", Bool, lambda m: locked.append(m.data))
    r.rt.scheduler.run_until(0.3)
    assert locked == [True]


def test_winner_timeout_publishes_one_zero_from_the_timer() -> None:
    r = Rig()
    nav = r.rt.bus.publisher("/nav_vel1", Twist)
    nav.publish(_cmd(0.4))
    r.rt.scheduler.run_until(2.0)
    assert r.seen == [(0.0, 0.4), (pytest.approx(0.52), 0.0)]

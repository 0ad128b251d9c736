"""``ZenohLink``: bridges chosen bus topics, services and actions over eclipse-zenoh.

One link per process.  It opens a Zenoh session (peer mode with explicit endpoints and no
multicast scouting by default; ``mode: client`` goes through a router), announces itself
with a liveliness token in rmw_zenoh's layout, and then:

* :meth:`export_topic` / :meth:`import_topic` carry a topic as ROS 2 CDR on its rmw_zenoh
  key (:mod:`.keys`).  ``keep_last(depth)`` stays the receiving subscription's queue; a
  latched (transient-local) topic keeps its last ``depth`` payloads in a queryable store
  that a late joiner reads when it imports the topic (``/map`` reaches a robot started
  after the base).
* Services and actions (:mod:`.remote_calls`) cross as Zenoh queries plus puts.
* Clocks: every ``sync_period`` the link probes each peer's clock queryable (NTP-style,
  :mod:`.clock_sync`); received stamps are shifted by the peer's estimated offset when
  ``clock.compensate`` is on, and nothing from a peer is delivered before its first
  estimate.
* Heartbeats: every ``sync_period`` of its own loop each process puts a heartbeat;
  :meth:`peer_up` is false when a peer's has not arrived for ``link_timeout`` (a stalled
  base counts as a lost one).
* Impairments (:mod:`.impairments`) drop or delay this process's traffic for tests.

Zenoh calls back on its own threads; everything that touches the bus is handed to the
scheduler with :meth:`Scheduler.post`, so nodes never see another thread.  The other
way, on a wall clock the loop only encodes (CDR: a few us) and queues what it sends;
the link's sender thread does the Zenoh ``put`` (:class:`.outbox.Outbox`), which on loopback
TCP took 75 us at the median and 0.5-5 ms at p99 per call -- on a robot that time
was spent inside the simulator's scan tick, ahead of the costmap and controller.  In
lockstep the loop puts directly (its messages must stay ordered with its time
announcements).
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import struct
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING, Any

import zenoh

from navstack.core.errors import BusError, ConfigError
from navstack.runtime.bus import DEFAULT_QOS, Publisher, QoS
from navstack.runtime.node import Runtime
from navstack.runtime.recording.convert import RosCodec
from navstack.runtime.transports.clock_sync import OffsetEstimator, exchange_sample
from navstack.runtime.transports.config import TransportSection
from navstack.runtime.transports.impairments import ImpairedLink
from navstack.runtime.transports.keys import (
    liveliness_token,
    namespaced,
    navstack_key,
    qos_string,
    topic_key,
)
from navstack.runtime.transports.outbox import Outbox
from navstack.runtime.transports.payloads import shift_stamps

if TYPE_CHECKING:
    from navstack.runtime.transports.lockstep import Lockstep

_log = logging.getLogger("navstack.transport")
_PROBE = struct.Struct("<d32s")  # t1, prober's name
_ANSWER = struct.Struct("<ddd")
#: rmw_zenoh-style attachment: sequence number, source timestamp [ns], 16-byte source gid
_ATTACHMENT = struct.Struct("<qq16s")
#: lockstep: the sender's elapsed simulated time, appended to every message's attachment
MARK = struct.Struct("<d")


def direct(fn: Callable[[zenoh.Sample], None]) -> zenoh.handlers.Callback:
    """A subscriber callback run on Zenoh's receiving thread in arrival order (not, as by
    default, on a thread of its own per subscriber, which reorders samples of different
    keys): for callbacks that never block.  Lockstep relies on a peer's samples arriving
    before its time announcement that follows them."""
    return zenoh.handlers.Callback(fn, indirect=False)


def attachment_bytes(sample: zenoh.Sample | zenoh.Query) -> bytes | None:
    """A sample's or query's attachment as bytes (``None`` without one)."""
    att = sample.attachment
    return None if att is None else att.to_bytes()


@dataclass
class PeerState:
    """What this process knows about one peer: clock estimate and last contact."""

    name: str
    estimator: OffsetEstimator = field(default_factory=OffsetEstimator)
    last_heard: float = -math.inf  # process clock of the last heartbeat received
    probes: int = 0
    answered: int = 0


@dataclass
class TopicStats:
    """Per imported topic: messages, drops and one-way latencies [s] (same-host clocks)."""

    received: int = 0
    dropped: int = 0
    latencies: deque[float] = field(default_factory=lambda: deque(maxlen=20000))


def zenoh_config(p: TransportSection) -> zenoh.Config:
    """The Zenoh session config of a transport section."""
    cfg = zenoh.Config()
    cfg.insert_json5("mode", json.dumps(p.mode))
    cfg.insert_json5("listen/endpoints", json.dumps(p.listen))
    cfg.insert_json5("connect/endpoints", json.dumps(p.connect))
    cfg.insert_json5("scouting/multicast/enabled", json.dumps(p.multicast_scouting))
    return cfg


class ZenohLink:
    """This process on the Zenoh network (see module docstring)."""

    def __init__(self, runtime: Runtime, params: TransportSection,
                 peers: Sequence[str] = ()) -> None:
        if params.kind != "zenoh":
            raise ConfigError(f"transport.kind is '{params.kind}': ZenohLink needs 'zenoh'")
        self.runtime = runtime
        self.scheduler = runtime.scheduler
        self.params = params
        self.codec = RosCodec()
        self.impairment = ImpairedLink(params.impairments)
        self.peers: dict[str, PeerState] = {
            name: PeerState(name, OffsetEstimator(window=16, max_age=30.0 * params.clock.rate))
            for name in peers}
        self.topic_stats: dict[str, TopicStats] = {}
        self._exports: dict[str, Callable[[Any, float], None]] = {}
        #: time [s] the loop thread spent encoding and putting exported messages, and
        #: how many (the link's own work on the loop, e.g. on a robot's control path)
        self.loop_work_s = 0.0
        self.loop_work_messages = 0
        #: lockstep time coupling (set by :class:`~.lockstep.Lockstep`), else ``None``
        self.lockstep: Lockstep | None = None
        self._fetchers: list[_LatchedFetcher] = []
        self._imports: set[str] = set()
        self._seq = 0
        self._outbox = Outbox(params.name)
        self._gid = params.name.encode()[:16].ljust(16, b"\0")
        self._entities: list[Any] = []
        self._closed = False
        try:
            self.session = zenoh.open(zenoh_config(params))
        except zenoh.ZError as exc:
            raise ConfigError(f"transport: cannot open the Zenoh session ({exc}); check "
                              f"transport.listen / transport.connect endpoints") from None
        self.opened_at = self.scheduler.clock()
        self.zid = str(self.session.zid())
        self._token = self.session.liveliness().declare_token(liveliness_token(
            params.domain_id, self.zid, 0, 0, "NN", params.namespace, params.name))
        self._entities.append(self.session.declare_queryable(
            navstack_key(params.domain_id, "clock", params.name), self._answer_probe))
        self.present: set[str] = set()
        self._entities.append(self.session.liveliness().declare_subscriber(
            f"@ros2_lv/{params.domain_id}/*/0/0/NN/**", self._on_node_token, history=True))
        runtime.bus.add_tap(self._tap)
        self._hb_key = navstack_key(params.domain_id, "hb", params.name)
        self._entities.append(self.session.declare_subscriber(
            navstack_key(params.domain_id, "hb", "*"), direct(self._on_heartbeat)))
        self.scheduler.create_timer(params.clock.sync_period, self._heartbeat)
        self._stop = threading.Event()
        #: NTP probes from the link thread (off in lockstep: the barrier exchanges clocks)
        self.probing = True
        self._periodic: list[Callable[[], None]] = []
        self._sync_thread = threading.Thread(target=self._sync_loop, name="navstack-clock",
                                             daemon=True)
        self._sync_thread.start()

    # --- time and impairments ---------------------------------------------------------
    def link_time(self) -> float:
        """Seconds since the link opened on this process's clock (impairment schedule)."""
        return self.scheduler.clock() - self.opened_at

    def passes(self, mark: bytes | None = None) -> bool:
        """Whether a message sent or received now survives the configured impairments
        (lockstep: a received message carrying ``mark`` is judged at its delivery time)."""
        if mark is not None and self.lockstep is not None:
            t = self.lockstep.arrival(mark)
            if t is not None:
                return self.impairment.passes(t - self.opened_at)
        return self.impairment.passes(self.link_time())

    def mark(self) -> bytes | None:
        """Lockstep: this loop's elapsed time for the receiver's delivery time (attached
        to every message); ``None`` on a wall clock."""
        return None if self.lockstep is None else self.lockstep.mark()

    def release(self) -> None:
        """Before blocking on a call to a peer: what the loop queued goes out first (a
        cancel before the next goal); lockstep: let the peer run up to the call."""
        self._outbox.flush()
        if self.lockstep is not None:
            self.lockstep.release()

    def started(self) -> bool:
        """Every peer's clock is estimated and every latched import has been read."""
        return (all(self.ready(p) for p in self.peers)
                and all(f.fetched for f in self._fetchers))

    def deliver(self, fn: Callable[..., Any], *args: Any, mark: bytes | None = None) -> None:
        """Hand ``fn(*args)`` to the scheduler, ``impairments.delay`` late (lockstep: at
        the time ``mark`` fixes, :meth:`.Lockstep.arrival`)."""
        delay = self.params.impairments.delay
        if self.lockstep is not None:
            t = self.lockstep.arrival(mark)
            if t is not None:
                self.scheduler.post_at(t + delay, fn, *args)
                return
        if delay > 0.0:
            timer = threading.Timer(delay / self.params.clock.rate, self.scheduler.post,
                                    (fn, *args))
            timer.daemon = True
            timer.start()
        else:
            self.scheduler.post(fn, *args)

    # --- clocks -------------------------------------------------------------------------
    def _answer_probe(self, query: zenoh.Query) -> None:
        t2 = self.scheduler.clock()
        if self._closed or not self.passes() or query.payload is None:
            return
        raw = query.payload.to_bytes()
        if len(raw) != _PROBE.size:
            return
        t1, who = _PROBE.unpack(raw)
        query.reply(query.key_expr, _ANSWER.pack(t1, t2, self.scheduler.clock()))
        del who

    def _probe(self, peer: PeerState) -> None:
        key = navstack_key(self.params.domain_id, "clock", peer.name)
        peer.probes += 1
        if not self.passes():
            return
        t1 = self.scheduler.clock()
        timeout = max(0.05, self.params.link_timeout / self.params.clock.rate)
        probe = _PROBE.pack(t1, self.params.name.encode())
        for reply in self.session.get(key, payload=probe, timeout=timeout):
            t4 = self.scheduler.clock()
            if reply.ok is None or not self.passes():
                continue
            echoed, t2, t3 = _ANSWER.unpack(reply.ok.payload.to_bytes())
            if echoed != t1:
                continue
            peer.estimator.add(exchange_sample(t1, t2, t3, t4))
            peer.answered += 1

    def _sync_loop(self) -> None:
        period = self.params.clock.sync_period / self.params.clock.rate
        while not self._stop.is_set():
            start = time.monotonic()
            for peer in list(self.peers.values()) if self.probing else ():
                try:
                    self._probe(peer)
                except zenoh.ZError as exc:  # session closing under us
                    _log.debug("clock probe to %s failed: %s", peer.name, exc)
            for job in list(self._periodic):
                job()
            self._stop.wait(max(0.0, period - (time.monotonic() - start)))

    def _on_node_token(self, sample: zenoh.Sample) -> None:
        name = str(sample.key_expr).rsplit("/", 1)[-1]
        if sample.kind == zenoh.SampleKind.PUT:
            self.present.add(name)
        else:
            self.present.discard(name)

    def add_periodic(self, job: Callable[[], None]) -> None:
        """Run ``job`` on the link thread after every clock exchange round."""
        self._periodic.append(job)

    def peer(self, name: str) -> PeerState:
        state = self.peers.get(name)
        if state is None:
            raise BusError(f"'{name}' is not a peer of link '{self.params.name}' "
                           f"(peers: {', '.join(self.peers) or 'none'})")
        return state

    def offset(self, peer: str) -> float:
        """Estimated offset of ``peer``'s clock over ours [s]."""
        return self.peer(peer).estimator.offset

    def send(self, put: Callable[..., Any], *args: Any, **kwargs: Any) -> None:
        """Run ``put(*args, **kwargs)`` (a Zenoh put) for the loop: on the sender
        thread on a wall clock, at once in lockstep (see module docstring)."""
        if self.lockstep is not None or self._closed:
            put(*args, **kwargs)
        else:
            self._outbox.submit(partial(put, *args, **kwargs))

    def put(self, key: str, payload: bytes, attachment: bytes | None = None) -> None:
        """``session.put`` through :meth:`send`."""
        self.send(self.session.put, key, payload, attachment=attachment)

    def send_stats(self) -> dict[str, float]:
        """Puts done by the sender thread and the time they took [s]."""
        return {"puts": self._outbox.sent, "put_s": self._outbox.put_s}

    def _heartbeat(self) -> None:
        if not self._closed and self.passes():
            self.put(self._hb_key, self.params.name.encode(), attachment=self.mark())

    def _on_heartbeat(self, sample: zenoh.Sample) -> None:
        mark = attachment_bytes(sample)
        if self._closed or not self.passes(mark):
            return
        peer = self.peers.get(sample.payload.to_bytes().decode(errors="replace"))
        if peer is not None:
            heard = self.lockstep.arrival(mark) if self.lockstep is not None else None
            peer.last_heard = self.scheduler.clock() if heard is None else heard

    def peer_up(self, peer: str) -> bool:
        """Whether ``peer``'s heartbeat (sent every ``sync_period`` from its loop) arrived
        within ``link_timeout`` seconds of this process's clock."""
        return self.scheduler.clock() - self.peer(peer).last_heard <= self.params.link_timeout

    def ready(self, peer: str) -> bool:
        """Whether ``peer``'s clock has been estimated (its messages are delivered)."""
        return self.peer(peer).estimator.count >= 3

    def compensate(self, msg: Any, peer: str) -> Any:
        """``msg`` with its stamps moved from ``peer``'s clock to ours (if enabled)."""
        if not self.params.clock.compensate:
            return msg
        return shift_stamps(msg, -self.offset(peer))

    # --- topics -------------------------------------------------------------------------
    def _attachment(self) -> bytes:
        self._seq += 1
        return _ATTACHMENT.pack(self._seq, time.time_ns(), self._gid) + (self.mark() or b"")

    def export_topic(self, local: str, msg_type: type, *, qos: QoS = DEFAULT_QOS,
                     remote: str | None = None) -> str:
        """Publish every message of bus topic ``local`` on the wire as
        ``<namespace>/<remote or local>``; returns that full name."""
        local = namespaced("", local)
        if local in self._imports:
            raise BusError(f"topic '{local}' is imported by this link; exporting it too "
                           f"would loop it back")
        full = namespaced(self.params.namespace, remote or local)
        ros_type = self.codec.ros_type(msg_type, local)
        d = self.params.domain_id
        pub = self.session.declare_publisher(
            topic_key(d, full, ros_type),
            congestion_control=(zenoh.CongestionControl.BLOCK if qos.latched
                                else zenoh.CongestionControl.DROP))
        self._entities.append(pub)
        self._entities.append(self.session.liveliness().declare_token(liveliness_token(
            d, self.zid, 0, len(self._entities), "MP", self.params.namespace, self.params.name,
            full, ros_type, qos_string(qos.depth, qos.latched))))
        store: deque[tuple[bytes, bytes]] | None = None
        if qos.latched:
            store = deque(maxlen=qos.depth)
            latched_key = navstack_key(d, "latched", full)
            held = store

            def answer(query: zenoh.Query) -> None:
                if not self.passes():
                    return
                for payload, attachment in list(held):
                    query.reply(latched_key, payload, attachment=attachment)

            self._entities.append(self.session.declare_queryable(latched_key, answer))

        def send(msg: Any, _now: float) -> None:
            payload = self.codec.serialize(msg)
            attachment = self._attachment()
            if store is not None:
                store.append((payload, attachment))
            if self.passes():
                self.send(pub.put, payload, attachment=attachment)

        self._exports[local] = send
        return full

    def _tap(self, topic: str, msg: Any, now: float) -> None:
        send = self._exports.get(topic)
        if send is not None and not self._closed:
            t0 = time.perf_counter()
            send(msg, now)
            self.loop_work_s += time.perf_counter() - t0
            self.loop_work_messages += 1

    def import_topic(self, remote_full: str, msg_type: type, *, peer: str,
                     local: str | None = None, qos: QoS = DEFAULT_QOS) -> str:
        """Deliver ``remote_full`` from ``peer`` onto bus topic ``local`` (default: the
        same name); stamps are compensated; returns the local name."""
        remote_full = namespaced("", remote_full)
        local = namespaced("", local or remote_full)
        if local in self._exports:
            raise BusError(f"topic '{local}' is exported by this link; importing it too "
                           f"would loop it back")
        self.peer(peer)
        self._imports.add(local)
        ros_type = self.codec.ros_type(msg_type, local)
        d = self.params.domain_id
        pub: Publisher[Any] = self.runtime.bus.publisher(local, msg_type, qos)
        stats = self.topic_stats.setdefault(local, TopicStats())

        def on_sample(sample: zenoh.Sample) -> None:
            if self._closed:
                return
            raw = attachment_bytes(sample)
            mark = raw[_ATTACHMENT.size:] if raw is not None else None
            if not self.passes(mark) or not self.ready(peer):
                stats.dropped += 1
                return
            if raw is not None and len(raw) == _ATTACHMENT.size:  # (not in lockstep)
                _, sent_ns, _ = _ATTACHMENT.unpack(raw)
                stats.latencies.append((time.time_ns() - sent_ns) * 1e-9)
            try:
                msg = self.codec.deserialize(sample.payload.to_bytes(), ros_type)
            except Exception as exc:  # rosbags raises plain errors on bad CDR
                stats.dropped += 1
                _log.warning("%s: dropped a malformed %s sample: %s", local, ros_type, exc)
                return
            stats.received += 1
            self.deliver(pub.publish, self.compensate(msg, peer), mark=mark or None)

        self._entities.append(self.session.declare_subscriber(
            topic_key(d, remote_full, ros_type), direct(on_sample)))
        self._entities.append(self.session.liveliness().declare_token(liveliness_token(
            d, self.zid, 0, len(self._entities), "MS", self.params.namespace, self.params.name,
            remote_full, ros_type, qos_string(qos.depth, qos.latched))))
        if qos.latched:
            self._entities.append(_LatchedFetcher(self, remote_full, on_sample, peer))
        return local

    # --- status and shutdown ----------------------------------------------------------------
    def health(self) -> dict[str, dict[str, float | int | bool]]:
        """Per peer: estimated offset and round trip [s], seconds since last heard, up."""
        now = self.scheduler.clock()
        return {p.name: {"offset_s": p.estimator.offset, "round_trip_s": p.estimator.delay,
                         "last_heard_s": now - p.last_heard, "up": self.peer_up(p.name),
                         "exchanges": p.answered, "probes": p.probes,
                         "compensated": self.params.clock.compensate}
                for p in self.peers.values()}

    def close(self) -> None:
        if self._closed:
            return
        self._outbox.close()
        self._closed = True
        self._stop.set()
        self._sync_thread.join(timeout=2.0)
        for entity in reversed(self._entities):
            undeclare = getattr(entity, "undeclare", None)
            if undeclare is not None:
                with contextlib.suppress(zenoh.ZError):
                    undeclare()
        self._token.undeclare()
        self.session.close()


class _LatchedFetcher:
    """Reads a latched topic's store once the peer's clock is known (late joiner), then
    again whenever the peer comes back after being unreachable."""

    def __init__(self, link: ZenohLink, remote_full: str,
                 on_sample: Callable[[zenoh.Sample], None], peer: str) -> None:
        self.link, self.on_sample, self.peer = link, on_sample, peer
        self.key = navstack_key(link.params.domain_id, "latched", remote_full)
        self.fetched = False
        link._fetchers.append(self)
        link.add_periodic(self._poll)

    def _poll(self) -> None:
        if self.fetched or not self.link.ready(self.peer):
            return
        got = False
        for reply in self.link.session.get(self.key, timeout=1.0):
            if reply.ok is not None:
                self.on_sample(reply.ok)
                got = True
        self.fetched = got

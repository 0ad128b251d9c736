"""Services and actions across a :class:`ZenohLink` (navstack keys, JSON envelopes).

Service ``S`` of process ``P``: a queryable on ``<domain>/@navstack/srv/<ns>/<S>``; the
caller's bus gets a proxy handler that queries it and blocks for the answer (at most
``timeout`` seconds; no answer is a :class:`LinkError` the caller sees as a failed call).

Action ``A``: ``.../act/<ns>/<A>/goal`` is a queryable answering accept/reject at once;
feedback and the result come back as puts on ``.../fb`` and ``.../result``; ``.../cancel``
and ``.../ack`` go the other way.  A result is re-sent until the client acknowledges it,
so a goal that ends during a link blackout still ends on the client once the link is
back -- a goal never ends silently.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
import uuid
from typing import Any

import zenoh

from navstack.core.errors import BusError
from navstack.runtime.actions import (
    ActionClient,
    ActionResult,
    ActionServer,
    GoalHandle,
    GoalStatus,
)
from navstack.runtime.transports.keys import namespaced, navstack_key
from navstack.runtime.transports.payloads import decode_envelope, encode_envelope
from navstack.runtime.transports.zenoh_link import ZenohLink, attachment_bytes, direct

_log = logging.getLogger("navstack.transport")


class LinkError(BusError):
    """A remote service or action did not answer over the link."""


def _wait_in_loop(link: ZenohLink, fn: Any, timeout: float,
                  mark: bytes | None = None) -> tuple[bool, Any]:
    """Run ``fn()`` in the scheduler loop from a Zenoh thread (lockstep: at the time the
    caller's ``mark`` fixes); wait for its value."""
    done = threading.Event()
    box: list[Any] = []

    def run() -> None:
        try:
            box.append((True, fn()))
        except Exception as exc:  # the error travels back to the caller as text
            box.append((False, f"{type(exc).__name__}: {exc}"))
        done.set()

    if mark is not None and link.lockstep is not None:
        link.deliver(run, mark=mark)
    else:
        link.scheduler.post(run)
    if not done.wait(timeout):
        return False, "the server's loop did not answer in time"
    ok, value = box[0]
    return ok, value


def serve_service(link: ZenohLink, name: str, peer: str, timeout: float = 2.0) -> str:
    """Answer ``peer``'s queries for bus service ``name``; returns the key.  Stamps are
    compensated by the receiver, in both directions."""
    key = navstack_key(link.params.domain_id, "srv", namespaced(link.params.namespace, name))

    def on_query(query: zenoh.Query) -> None:
        mark = attachment_bytes(query)
        if not link.passes(mark) or query.payload is None:
            return
        try:
            request = link.compensate(decode_envelope(query.payload.to_bytes()), peer)
        except BusError as exc:
            query.reply(key, encode_envelope({"ok": False, "value": str(exc)}))
            return
        ok, value = _wait_in_loop(link, lambda: link.runtime.bus.call(name, request), timeout,
                                  mark)
        query.reply(key, encode_envelope({"ok": ok, "value": value}))

    link._entities.append(link.session.declare_queryable(key, on_query))
    return key


def proxy_service(link: ZenohLink, remote_full: str, local: str, peer: str,
                  timeout: float = 3.0) -> None:
    """Advertise bus service ``local`` that calls ``remote_full`` on ``peer``."""
    key = navstack_key(link.params.domain_id, "srv", namespaced("", remote_full))
    wait = timeout / link.params.clock.rate

    def call(request: Any) -> Any:
        if not link.passes():
            raise LinkError(f"service '{remote_full}' on '{peer}': link down (impaired)")
        payload = encode_envelope(request)
        link.release()
        for reply in link.session.get(key, payload=payload, timeout=wait,
                                      attachment=link.mark()):
            if reply.ok is None:
                continue
            answer = decode_envelope(reply.ok.payload.to_bytes())
            if not answer["ok"]:
                raise LinkError(f"service '{remote_full}' on '{peer}' failed: "
                                f"{answer['value']}")
            return link.compensate(answer["value"], peer)
        raise LinkError(f"service '{remote_full}' on '{peer}': no answer within "
                        f"{timeout:g} s (is '{peer}' running and the link up?)")

    link.runtime.bus.advertise_service(local, call)


def serve_action(link: ZenohLink, name: str, peer: str, timeout: float = 2.0) -> str:
    """Accept goals for bus action ``name`` from ``peer``; returns the key prefix."""
    full = namespaced(link.params.namespace, name)
    base = navstack_key(link.params.domain_id, "act", full)
    handles: dict[str, GoalHandle[Any]] = {}
    unacked: dict[str, tuple[bytes, bytes | None]] = {}
    lock = threading.Lock()
    client: ActionClient[Any] = ActionClient(link.runtime.bus, name)

    def put(suffix: str, payload: bytes, mark: bytes | None = None) -> None:
        if link.passes():
            link.put(f"{base}/{suffix}", payload, attachment=mark)

    def submit(gid: str, goal: Any) -> ActionResult | None:
        def on_feedback(fb: Any) -> None:
            put("fb", encode_envelope({"gid": gid, "feedback": fb}), link.mark())

        def on_done(result: ActionResult) -> None:
            payload, mark = encode_envelope({"gid": gid, "result": result}), link.mark()
            with lock:
                unacked[gid] = (payload, mark)
            put("result", payload, mark)

        handle = client.send_goal(link.compensate(goal, peer), on_feedback)
        handles[gid] = handle
        if handle.status is GoalStatus.REJECTED:
            return handle.result
        handle.add_done_callback(on_done)
        return None

    def on_goal(query: zenoh.Query) -> None:
        mark = attachment_bytes(query)
        if not link.passes(mark) or query.payload is None:
            return
        try:
            req = decode_envelope(query.payload.to_bytes())
        except BusError as exc:
            query.reply(f"{base}/goal", encode_envelope({"rejected": ActionResult(
                GoalStatus.REJECTED, 1, f"action '{name}': {exc}")}))
            return
        ok, value = _wait_in_loop(link, lambda: submit(req["gid"], req["goal"]), timeout,
                                  mark)
        if not ok:
            value = ActionResult(GoalStatus.REJECTED, 1, f"action '{name}': {value}")
        query.reply(f"{base}/goal", encode_envelope({"rejected": value}))

    def on_cancel(sample: zenoh.Sample) -> None:
        mark = attachment_bytes(sample)
        if not link.passes(mark):
            return
        handle = handles.get(sample.payload.to_bytes().decode())
        if handle is not None:
            link.deliver(handle.cancel, mark=mark)

    def on_ack(sample: zenoh.Sample) -> None:
        if link.passes(attachment_bytes(sample)):
            with lock:
                unacked.pop(sample.payload.to_bytes().decode(), None)

    def resend() -> None:
        with lock:
            pending = list(unacked.values())
        for payload, mark in pending:
            put("result", payload, mark)

    s = link.session
    link._entities += [s.declare_queryable(f"{base}/goal", on_goal),
                       s.declare_subscriber(f"{base}/cancel", direct(on_cancel)),
                       s.declare_subscriber(f"{base}/ack", direct(on_ack))]
    link.add_periodic(resend)
    return base


class ActionProxy:
    """Bus action server ``local`` whose goals run on ``peer``'s server ``remote_full``."""

    _ids = itertools.count(1)

    def __init__(self, link: ZenohLink, remote_full: str, local: str, peer: str,
                 timeout: float = 3.0) -> None:
        self.link, self.peer, self.remote, self.timeout = link, peer, remote_full, timeout
        self.base = navstack_key(link.params.domain_id, "act", namespaced("", remote_full))
        self.handles: dict[str, GoalHandle[Any]] = {}
        self.server: ActionServer[Any] = ActionServer(link.runtime.bus, local, self._on_goal,
                                                      self._on_cancel)
        s = link.session
        link._entities += [s.declare_subscriber(f"{self.base}/fb", direct(self._on_feedback)),
                           s.declare_subscriber(f"{self.base}/result",
                                                direct(self._on_result))]
        self.goal_latency: list[float] = []
        #: outcomes seen by this proxy: "SUCCEEDED", "CANCELED", ..., "no_answer", "link_down"
        self.outcomes: dict[str, int] = {}

    def _count(self, what: str) -> None:
        self.outcomes[what] = self.outcomes.get(what, 0) + 1

    def _on_goal(self, handle: GoalHandle[Any]) -> bool | str:
        link = self.link
        if not link.passes():
            self._count("link_down")
            return f"action '{self.remote}' on '{self.peer}': link down (impaired)"
        gid = f"{link.params.name}-{next(self._ids)}-{uuid.uuid4().hex[:8]}"
        payload = encode_envelope({"gid": gid, "goal": handle.goal})
        self.handles[gid] = handle  # before the query: its feedback may beat the reply
        t0 = time.perf_counter()
        link.release()
        for reply in link.session.get(f"{self.base}/goal", payload=payload,
                                      timeout=self.timeout / link.params.clock.rate,
                                      attachment=link.mark()):
            if reply.ok is None:
                continue
            self.goal_latency.append(time.perf_counter() - t0)
            rejected = decode_envelope(reply.ok.payload.to_bytes())["rejected"]
            if rejected is not None:
                self.handles.pop(gid, None)
                self._count("REJECTED")
                return rejected.error_msg or "goal rejected by the remote server"
            return True
        self.handles.pop(gid, None)
        self._count("no_answer")
        return (f"action '{self.remote}' on '{self.peer}': no answer within "
                f"{self.timeout:g} s (is '{self.peer}' running and the link up?)")

    def _on_cancel(self, handle: GoalHandle[Any]) -> None:
        for gid, h in list(self.handles.items()):  # results pop from Zenoh's threads
            if h is handle:
                self.link.put(f"{self.base}/cancel", gid.encode(),
                                      attachment=self.link.mark())

    def _decode(self, sample: zenoh.Sample) -> Any:
        try:
            return decode_envelope(sample.payload.to_bytes())
        except BusError as exc:
            _log.warning("action '%s' on '%s': dropped a malformed message: %s",
                         self.remote, self.peer, exc)
            return None

    def _on_feedback(self, sample: zenoh.Sample) -> None:
        mark = attachment_bytes(sample)
        if not self.link.passes(mark):
            return
        msg = self._decode(sample)
        if msg is None:
            return
        handle = self.handles.get(msg["gid"])
        if handle is not None:
            fb = self.link.compensate(msg["feedback"], self.peer)
            self.link.deliver(handle.publish_feedback, fb, mark=mark)

    def _on_result(self, sample: zenoh.Sample) -> None:
        link = self.link
        mark = attachment_bytes(sample)
        if not link.passes(mark):
            return
        msg = self._decode(sample)
        if msg is None:
            return
        gid = msg["gid"]
        if not gid.startswith(link.params.name + "-"):
            return  # another client's goal on the same server
        link.put(f"{self.base}/ack", gid.encode(), attachment=link.mark())
        handle = self.handles.pop(gid, None)
        if handle is not None:
            result = link.compensate(msg["result"], self.peer)
            self._count(result.status.value)
            link.deliver(handle.finish, result, mark=mark)

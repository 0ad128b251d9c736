"""twist_mux arbitration (ros-teleop ``twist_mux``), pure: no bus, times passed in.

Velocity inputs (``topics:``) and locks (``locks:``) each have a ``name``, a ``topic``, a
``timeout`` [s] and a ``priority`` in [0, 255].  twist_mux's rules (``topic_handle.hpp``,
``twist_mux.cpp``):

* an input or a lock has *expired* when ``timeout > 0`` and no message arrived for more
  than ``timeout`` seconds; one that never published has expired (its stamp starts at 0);
* a lock is active while its last value is true or it has expired (a dead-man switch);
  the lock priority is the highest priority of the active locks (0 when none is);
* an input is masked when it has expired or its priority is below the lock priority; the
  winner is the unmasked input of highest priority, the first in file order on a tie;
* a message is forwarded when its input is the winner at that moment.

Departures, documented in ``docs/command_path.md``: a zero is published when a lock
engages over the running input and in answer to every masked message of a live input
while locked (twist_mux drops them and the base keeps its last command), and one zero
when the winner times out with no other input live.  Both layouts of the YAML load: ROS 1
lists (``topics: [{name, topic, timeout, priority}]``) and ROS 2 maps under
``twist_mux: ros__parameters:`` (``topics: {name: {topic, timeout, priority}}``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

from pydantic import Field

from navstack.core.config_files import ros_parameters
from navstack.core.errors import ConfigError, ConfigErrors
from navstack.core.params import Params

__all__ = ["MuxAction", "MuxEntry", "TwistMux", "TwistMuxParams", "twist_mux_params"]


class MuxEntry(Params):
    """One input or lock: twist_mux's ``name``/``topic``/``timeout``/``priority`` (all four
    required, as twist_mux's ``fetch_param`` requires them)."""

    name: str = Field(min_length=1)
    topic: str = Field(min_length=1)
    timeout: float = Field(ge=0.0, allow_inf_nan=False)
    """[s]; 0 never expires."""
    priority: int = Field(ge=0, le=255)
    """Higher wins; twist_mux clamps to [0, 255], navstack refuses values outside."""


class TwistMuxParams(Params):
    """A twist_mux configuration (twist_mux's keys plus navstack's, all with defaults but
    the lists)."""

    topics: list[MuxEntry] = Field(min_length=1)
    locks: list[MuxEntry] = Field(default_factory=list)
    use_stamped: bool = False
    """twist_mux >= 4.4: inputs and output are ``geometry_msgs/TwistStamped``."""
    cmd_vel_out: str = "/cmd_vel"
    """The output topic (twist_mux's ``cmd_vel_out``, remapped in a launch file)."""
    timeout_check_period: float = Field(0.02, gt=0.0, allow_inf_nan=False)
    """[s] how often expiries are checked between messages (navstack)."""
    zero_when_locked: bool = True
    """Publish zero when a lock masks the running input and for masked messages (navstack;
    twist_mux behaves as ``false``)."""
    zero_on_timeout: bool = True
    """Publish one zero when the winner expires with no other input live (navstack)."""


def _entries(value: Any, kind: str, file: str, key_path: str) -> list[dict[str, Any]]:
    """ROS 1 list or ROS 2 map of entries -> list of dicts with ``name`` (file order)."""
    if value is None:
        return []
    if isinstance(value, Mapping):
        out = []
        for name, entry in value.items():
            if not isinstance(entry, Mapping):
                raise ConfigError(f"a {kind} entry must be a mapping with topic, timeout and "
                                  "priority", file=file, key_path=f"{key_path}.{name}")
            out.append({"name": str(name), **entry})
        return out
    if isinstance(value, list):
        for i, entry in enumerate(value):
            if not isinstance(entry, Mapping):
                raise ConfigError(f"a {kind} entry must be a mapping with name, topic, "
                                  "timeout and priority", file=file, key_path=f"{key_path}[{i}]")
        return [dict(e) for e in value]
    raise ConfigError(f"must be a list of {kind} entries (ROS 1) or a mapping name -> entry "
                      "(ROS 2)", file=file, key_path=key_path)


def _renamed(path: str, named: Mapping[str, str]) -> str:
    for indexed, name in named.items():
        if path == indexed or path.startswith(indexed + "."):
            return name + path[len(indexed):]
    return path


def twist_mux_params(data: Mapping[str, Any], *, file: str = "",
                     overrides: Mapping[str, Any] | None = None) -> TwistMuxParams:
    """A twist_mux configuration from a YAML document in either layout: the top level
    (``topics:``, ``locks:``), or ``twist_mux: ros__parameters:`` (also inside a Nav2
    parameter file).  Errors name ``file`` and the key path; duplicate names or topics are
    refused."""
    if "twist_mux" in data:
        params = ros_parameters(data, "twist_mux", file=file, required=True)
        prefix = "twist_mux.ros__parameters"
    else:
        params, prefix = dict(data), ""
    raw = {**params, **(overrides or {})}

    def key(k: str) -> str:
        return f"{prefix}.{k}" if prefix else k

    named: dict[str, str] = {}  # "topics[0]" -> "topics.navigation" (ROS 2 map layout)
    for kind in ("topics", "locks"):
        value = raw.get(kind)
        raw[kind] = _entries(value, kind[:-1], file, key(kind))
        if isinstance(value, Mapping):
            named.update({key(f"{kind}[{i}]"): key(f"{kind}.{e['name']}")
                          for i, e in enumerate(raw[kind])})
    try:
        out = TwistMuxParams.from_mapping(raw, file=file, key_path=prefix)
    except ConfigError as exc:
        errors = exc.errors if isinstance(exc, ConfigErrors) else [exc]
        renamed = [ConfigError(e.reason, file=e.file, key_path=_renamed(e.key_path, named),
                               suggestion=e.suggestion) for e in errors]
        raise (renamed[0] if len(renamed) == 1 else ConfigErrors(renamed)) from None
    for kind, entries in (("topics", out.topics), ("locks", out.locks)):
        seen: dict[str, str] = {}
        for e in entries:
            if e.name in seen:
                raise ConfigError(f"duplicate {kind[:-1]} name '{e.name}'", file=file,
                                  key_path=key(kind), suggestion="give every entry its own name")
            seen[e.name] = e.topic
    topics = [e.topic for e in (*out.topics, *out.locks)]
    for t in topics:
        if topics.count(t) > 1:
            raise ConfigError(f"topic '{t}' is used by more than one entry", file=file,
                              key_path=prefix or "topics",
                              suggestion="each input and lock needs its own topic")
    return out


class MuxAction(Enum):
    """What the node does with a message (or a timer tick)."""

    NONE = "none"
    FORWARD = "forward"
    """Publish the input's message on the output."""
    ZERO = "zero"
    """Publish a zero twist on the output."""


@dataclass
class _Slot:
    entry: MuxEntry
    stamp: float | None = None
    value: bool = False  # locks only

    def expired(self, now: float) -> bool:
        t = self.entry.timeout
        return t > 0.0 and (self.stamp is None or now - self.stamp > t)


class TwistMux:
    """The arbitration state of one mux: feed it messages and ticks, it says what to
    publish.  ``now`` is the caller's clock [s]."""

    def __init__(self, params: TwistMuxParams) -> None:
        self.params = params
        self.inputs = {e.name: _Slot(e) for e in params.topics}
        self.locks = {e.name: _Slot(e) for e in params.locks}
        self.active: str | None = None
        """The input that won at the last evaluation (``None``: no live input)."""
        self.zeros = 0
        """Zero twists asked for by the navstack departures (lock engaged, masked message,
        winner timed out)."""
        self._lock_priority = 0

    # --- twist_mux's queries -------------------------------------------------------------
    def lock_priority(self, now: float) -> int:
        """Highest priority of the active locks (twist_mux ``getLockPriority``)."""
        best = 0
        for slot in self.locks.values():
            if (slot.value or slot.expired(now)) and slot.entry.priority > best:
                best = slot.entry.priority
        return best

    def active_locks(self, now: float) -> list[str]:
        return [n for n, s in self.locks.items() if s.value or s.expired(now)]

    def masked(self, name: str, now: float) -> bool:
        slot = self.inputs[name]
        return slot.expired(now) or slot.entry.priority < self.lock_priority(now)

    def winner(self, now: float) -> str | None:
        """The unmasked input of highest priority, first in file order on a tie
        (twist_mux ``hasPriority``)."""
        lock = self.lock_priority(now)
        best, name = -1, None
        for n, slot in self.inputs.items():
            if slot.expired(now) or slot.entry.priority < lock:
                continue
            if slot.entry.priority > best:
                best, name = slot.entry.priority, n
        return name

    # --- events ---------------------------------------------------------------------------
    def on_input(self, name: str, now: float) -> MuxAction:
        """A message on input ``name`` arrived at ``now``."""
        slot = self.inputs[name]
        slot.stamp = now
        if slot.entry.priority < self.lock_priority(now):
            self._refresh(now)
            return self._zero() if self.params.zero_when_locked else MuxAction.NONE
        win = self.winner(now)
        self.active = win
        self._lock_priority = self.lock_priority(now)
        return MuxAction.FORWARD if win == name else MuxAction.NONE

    def on_lock(self, name: str, value: bool, now: float) -> MuxAction:
        """A ``std_msgs/Bool`` on lock ``name`` arrived at ``now``."""
        slot = self.locks[name]
        slot.stamp, slot.value = now, bool(value)
        return self.tick(now)

    def tick(self, now: float) -> MuxAction:
        """Re-evaluate expiries (locks engaging by timeout, the winner going silent)."""
        before, lock_before = self.active, self._lock_priority
        lock = self.lock_priority(now)
        win = self.winner(now)
        self._lock_priority, self.active = lock, win
        if lock > lock_before and self.params.zero_when_locked:
            # a lock engaged: stop unless an input at or above it is running
            if before is not None and before != win:
                return self._zero()
            if before is None and win is None:
                return self._zero()
        if before is not None and win is None and self.params.zero_on_timeout:
            return self._zero()
        return MuxAction.NONE

    def _refresh(self, now: float) -> None:
        self.active = self.winner(now)
        self._lock_priority = self.lock_priority(now)

    def _zero(self) -> MuxAction:
        self.zeros += 1
        return MuxAction.ZERO

    def state(self, now: float) -> dict[str, Any]:
        """For dashboards: the winner, the lock priority and each entry's age and status."""
        def age(slot: _Slot) -> float | None:
            return None if slot.stamp is None else round(now - slot.stamp, 3)

        return {
            "active": self.winner(now),
            "lock_priority": self.lock_priority(now),
            "locked_by": self.active_locks(now),
            "zeros": self.zeros,
            "inputs": {n: {"topic": s.entry.topic, "priority": s.entry.priority,
                           "age_s": age(s), "masked": self.masked(n, now)}
                       for n, s in self.inputs.items()},
            "locks": {n: {"topic": s.entry.topic, "priority": s.entry.priority,
                          "age_s": age(s), "value": s.value, "expired": s.expired(now)}
                      for n, s in self.locks.items()},
        }

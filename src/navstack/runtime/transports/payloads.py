"""What crosses the wire: CDR for topics, a typed JSON envelope for services/actions.

* **Topics** carry ROS 2 CDR (XCDR1 little endian) made by the recorder's
  :class:`~navstack.runtime.recording.convert.RosCodec` -- the same bytes a rosbag2 file
  holds -- so a ROS 2 subscriber on rmw_zenoh (or rosbags' ``deserialize_cdr``) reads
  them.  A type without a ROS 2 counterpart cannot be bridged
  (:class:`~navstack.runtime.recording.errors.UnsupportedTypeError` names it).
* **Services and actions** carry navstack's goal/result dataclasses, which have no
  Humble message (their Nav2 counterparts differ field by field), as JSON with a type tag
  per object; only dataclasses and enums of the message, navigation and action modules
  are ever instantiated on decode.
* **Stamps**: :func:`shift_stamps` moves every ``Header.stamp`` of a message by the
  estimated clock offset (compensation on receipt, issue 21).
"""

from __future__ import annotations

import base64
import dataclasses
import importlib
import json
from enum import Enum
from typing import Any

import numpy as np

from navstack.core.errors import BusError
from navstack.core.msgs import Clock, Header

#: modules whose classes a JSON envelope may name (never arbitrary imports)
ENVELOPE_MODULES = (
    "navstack.core.msgs",
    "navstack.navigation",
    "navstack.runtime.actions",
)


def _type_tag(obj: Any) -> str:
    cls = type(obj)
    return f"{cls.__module__}:{cls.__qualname__}"


def _resolve(tag: str) -> type:
    module, _, name = tag.partition(":")
    if not any(module == m or module.startswith(m + ".") for m in ENVELOPE_MODULES):
        raise BusError(f"payload names type '{tag}', outside the message modules "
                       f"({', '.join(ENVELOPE_MODULES)}); refusing to decode it")
    cls = getattr(importlib.import_module(module), name, None)
    if not isinstance(cls, type) or not (dataclasses.is_dataclass(cls)
                                         or issubclass(cls, Enum)):
        raise BusError(f"payload names type '{tag}', which is not a message dataclass "
                       f"or enum")
    return cls


def _to_json(obj: Any) -> Any:
    if obj is None or isinstance(obj, bool | int | float | str):
        return obj
    if isinstance(obj, Enum):
        return {"@e": _type_tag(obj), "v": obj.value}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, Any] = {"@t": _type_tag(obj)}
        for f in dataclasses.fields(obj):
            out[f.name] = _to_json(getattr(obj, f.name))
        return out
    if isinstance(obj, np.ndarray):
        arr = np.ascontiguousarray(obj)
        return {"@nd": arr.dtype.str, "shape": list(arr.shape),
                "b64": base64.b64encode(arr.tobytes()).decode()}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, tuple):
        return {"@tu": [_to_json(x) for x in obj]}
    if isinstance(obj, list):
        return [_to_json(x) for x in obj]
    if isinstance(obj, dict):
        return {"@d": [[_to_json(k), _to_json(v)] for k, v in obj.items()]}
    raise BusError(f"cannot send {type(obj).__name__} over the transport (not a message "
                   f"dataclass, enum, array or plain value)")


def _from_json(obj: Any) -> Any:
    if isinstance(obj, list):
        return [_from_json(x) for x in obj]
    if not isinstance(obj, dict):
        return obj
    if "@t" in obj:
        cls = _resolve(obj["@t"])
        kwargs = {k: _from_json(v) for k, v in obj.items() if k != "@t"}
        return cls(**kwargs)
    if "@e" in obj:
        return _resolve(obj["@e"])(obj["v"])
    if "@nd" in obj:
        raw = base64.b64decode(obj["b64"])
        return np.frombuffer(raw, dtype=np.dtype(obj["@nd"])).reshape(obj["shape"]).copy()
    if "@tu" in obj:
        return tuple(_from_json(x) for x in obj["@tu"])
    if "@d" in obj:
        return {_from_json(k): _from_json(v) for k, v in obj["@d"]}
    raise BusError(f"malformed envelope object with keys {sorted(obj)}")


def encode_envelope(obj: Any) -> bytes:
    """JSON bytes of a goal / result / request (dataclasses tagged with their type)."""
    return json.dumps(_to_json(obj), separators=(",", ":")).encode()


def decode_envelope(data: bytes) -> Any:
    """The object :func:`encode_envelope` encoded; a malformed payload is a ``BusError``."""
    try:
        raw = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BusError(f"malformed envelope payload: {exc}") from exc
    try:
        return _from_json(raw)
    except (TypeError, ValueError, KeyError) as exc:
        raise BusError(f"malformed envelope payload: {exc}") from exc


def shift_stamps(msg: Any, dt: float) -> Any:
    """``msg`` with every ``Header.stamp`` (and ``Clock.clock``) moved by ``dt`` seconds
    (frozen dataclasses are rebuilt; sequences of messages are walked)."""
    if dt == 0.0:
        return msg
    if isinstance(msg, Header):
        return dataclasses.replace(msg, stamp=msg.stamp + dt)
    if isinstance(msg, Clock):
        return dataclasses.replace(msg, clock=msg.clock + dt)
    if dataclasses.is_dataclass(msg) and not isinstance(msg, type):
        changes: dict[str, Any] = {}
        for f in dataclasses.fields(msg):
            value = getattr(msg, f.name)
            shifted = _shift_value(value, dt)
            if shifted is not value:
                changes[f.name] = shifted
        return dataclasses.replace(msg, **changes) if changes else msg
    return msg


def _shift_value(value: Any, dt: float) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return shift_stamps(value, dt)
    if isinstance(value, tuple | list) and value and dataclasses.is_dataclass(value[0]):
        items = [shift_stamps(v, dt) for v in value]
        return tuple(items) if isinstance(value, tuple) else items
    return value

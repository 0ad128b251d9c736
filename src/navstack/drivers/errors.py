"""Typed errors of the vehicle links.

A decoder never lets ``struct.error``, ``ValueError`` or a library's own exception out:
everything that is wrong with received bytes becomes a :class:`MalformedPacket` naming
the codec, what is wrong and a short hex/text excerpt of the data, so a driver can count
it and carry on.
"""

from __future__ import annotations

from navstack.core.errors import NavstackError

__all__ = ["EncodeError", "LinkError", "LinkUnavailable", "MalformedPacket", "excerpt"]


def excerpt(data: bytes | str, limit: int = 48) -> str:
    """A short printable view of ``data`` for error messages (hex for binary)."""
    if isinstance(data, str):
        text = data if len(data) <= limit else data[:limit] + "..."
        return repr(text)
    shown = data[:limit].hex(" ")
    return f"{len(data)} bytes [{shown}{' ...' if len(data) > limit else ''}]"


class LinkError(NavstackError):
    """Base of the vehicle-link errors."""


class MalformedPacket(LinkError, ValueError):
    """Received bytes that do not decode: wrong length, bad checksum, non-numeric or
    non-finite field, value out of range.  ``codec`` names the decoder, ``reason`` what
    is wrong; drivers count these per reason and never crash on them."""

    def __init__(self, codec: str, reason: str, data: bytes | str = b"") -> None:
        self.codec = codec
        self.reason = reason
        self.data = data
        super().__init__(f"{codec}: {reason}" + (f" in {excerpt(data)}" if data else ""))


class EncodeError(LinkError, ValueError):
    """A command cannot be put on the wire (NaN/inf, unknown mode)."""


class LinkUnavailable(LinkError):
    """A transport cannot be opened or is closed (port missing, address in use)."""

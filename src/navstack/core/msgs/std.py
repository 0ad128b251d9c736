"""std_msgs / builtin_interfaces equivalents.  Time is float seconds."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Header:
    """std_msgs/Header: ``stamp`` in seconds, ``frame_id`` the data's frame."""

    stamp: float = 0.0
    frame_id: str = ""


@dataclass(frozen=True, slots=True)
class Clock:
    """rosgraph_msgs/Clock: the simulation time in seconds."""

    clock: float = 0.0


@dataclass(frozen=True, slots=True)
class String:
    """std_msgs/String."""

    data: str = ""


@dataclass(frozen=True, slots=True)
class Bool:
    """std_msgs/Bool."""

    data: bool = False


@dataclass(frozen=True, slots=True)
class Float64:
    """std_msgs/Float64."""

    data: float = 0.0

"""Typed error hierarchy.

Every error carries what a user needs to fix the cause: the file, key, frame or
message involved and, where possible, a suggestion.  Nothing here is raised as a bare
``Exception``; callers catch the narrowest class they can handle.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(word: str, options: Iterable[str]) -> str:
    """Return ``" (did you mean 'x'?)"`` for the closest option, or ``""``."""
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


class NavstackError(Exception):
    """Base of every error raised by navstack."""


# --- configuration -------------------------------------------------------------------
class ConfigError(NavstackError):
    """A configuration value is missing, unknown, of the wrong type or out of range.

    ``str(err)`` is one line: ``FILE: key.path: message (did you mean 'x'?)``.
    """

    def __init__(self, message: str, *, file: str = "", key_path: str = "",
                 suggestion: str = "") -> None:
        self.file = file
        self.key_path = key_path
        self.reason = message
        self.suggestion = suggestion
        where = ": ".join(p for p in (file, key_path) if p)
        text = f"{where}: {message}" if where else message
        if suggestion:
            text += f" ({suggestion})"
        super().__init__(text)


class ConfigErrors(ConfigError):
    """Several configuration problems found in one file, reported together."""

    def __init__(self, errors: list[ConfigError]) -> None:
        self.errors = errors
        first = errors[0]
        super().__init__("; ".join(str(e) for e in errors), file=first.file)
        self.args = ("\n".join(str(e) for e in errors),)

    def __str__(self) -> str:
        return "\n".join(str(e) for e in self.errors)


class MapFileError(NavstackError):
    """A map file (YAML + image) is missing, unreadable or inconsistent."""


class UnknownNameError(NavstackError, KeyError):
    """A name (world, robot, plugin, topic) is not known; lists what is."""

    def __init__(self, kind: str, name: str, known: Iterable[str]) -> None:
        known = sorted(known)
        self.kind, self.name, self.known = kind, name, known
        msg = f"unknown {kind} '{name}'{did_you_mean(name, known)}; known: {', '.join(known)}"
        super().__init__(msg)

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


class InvalidMessage(NavstackError, ValueError):
    """A message failed validation (NaN/inf, wrong shape, bad frame)."""


# --- plugins ---------------------------------------------------------------------------
class PluginError(NavstackError):
    """Plugin registry misuse."""


class DuplicatePluginError(PluginError):
    """A plugin name or alias is registered twice."""


# --- TF ------------------------------------------------------------------------------
class TransformError(NavstackError, LookupError):
    """A transform could not be looked up (the architecture's TF ``LookupError``)."""


class UnknownFrameError(TransformError):
    """A frame has never been seen by the transform tree."""


class ConnectivityError(TransformError):
    """Both frames exist but no chain of edges joins them."""


class ExtrapolationError(TransformError):
    """The requested time lies outside the buffered window of an edge."""


class FrameConflictError(NavstackError, ValueError):
    """A transform would give a frame a second parent, close a loop, or mix static and
    dynamic publication of one edge."""


# --- runtime ---------------------------------------------------------------------------
class LifecycleError(NavstackError):
    """An illegal lifecycle transition was requested."""


class BusError(NavstackError):
    """Bus misuse: a topic published with two types, an unknown service, ..."""


# --- simulation ----------------------------------------------------------------------
class SimulationError(NavstackError):
    """The simulator was given something it cannot simulate."""


# --- planning ------------------------------------------------------------------------
class PlannerError(NavstackError):
    """Base for global planner failures (Nav2 ComputePathToPose error codes)."""


class StartOccupied(PlannerError):
    """The start pose is in lethal cost."""


class GoalOccupied(PlannerError):
    """The goal pose is in lethal cost."""


class StartOutsideMap(PlannerError):
    """The start pose is outside the costmap bounds."""


class GoalOutsideMap(PlannerError):
    """The goal pose is outside the costmap bounds."""


class NoValidPath(PlannerError):
    """The search exhausted the reachable space without reaching the goal."""


class PlannerTimeout(PlannerError):
    """The search exceeded its time or iteration budget."""


class PlannerCancelled(PlannerError):
    """The search was cancelled by the caller."""


# --- control ---------------------------------------------------------------------------
class ControllerError(NavstackError):
    """Base for local controller failures (Nav2 FollowPath error codes)."""


class NoValidControl(ControllerError):
    """No admissible velocity command was found this cycle."""


class InvalidPath(ControllerError):
    """The path given to a controller is empty, in the wrong frame or far from the robot
    (``nav2_core::InvalidPath``)."""


class PatienceExceeded(ControllerError):
    """The controller failed for longer than its failure tolerance."""


# --- behaviors -------------------------------------------------------------------------
class InvalidBehaviorGoal(NavstackError, ValueError):
    """A behavior goal field is out of range (Nav2 ``INVALID_INPUT``)."""

"""``WaypointFollower``: the FollowWaypoints action (Nav2 ``nav2_waypoint_follower``), and a
loader for waypoint YAML files.

Waypoints are sent one at a time as NavigateToPose goals.  A waypoint whose navigation
fails (FAILED or REJECTED) either ends the follow (``stop_on_failure: true``, Nav2's
default) with ``STOP_ON_MISSED_WAYPOINT`` and a reason naming the waypoint and the
navigator's reason, or is recorded as a ``MissedWaypoint`` and skipped.  The result
(``FollowWaypointsResult``) lists the missed waypoints; feedback gives the index and name
of the waypoint being driven to.  Cancel cancels the running navigation; a new
FollowWaypoints goal preempts the running one; if another client preempts our
NavigateToPose goal the follow ends CANCELED saying so.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path as FsPath
from typing import Any

import yaml

from navstack.core.errors import ConfigError, ConfigErrors, did_you_mean
from navstack.core.geometry import MAX_COORDINATE
from navstack.core.msgs import Header, Point, Pose, PoseStamped, Quaternion
from navstack.core.params import Params
from navstack.core.tf import QUATERNION_NORMALIZATION_TOLERANCE
from navstack.navigation import messages as m
from navstack.runtime.actions import (
    ActionClient,
    ActionResult,
    ActionServer,
    GoalHandle,
    GoalStatus,
)
from navstack.runtime.node import LifecycleState, Node, Runtime


class FollowWaypointsErrorCode(IntEnum):
    """nav2_msgs/FollowWaypoints error codes (Nav2 numbering; navstack addition)."""

    NONE = 0
    UNKNOWN = 600
    TASK_EXECUTOR_FAILED = 601
    NO_VALID_WAYPOINTS = 602
    STOP_ON_MISSED_WAYPOINT = 603


class WaypointFollowerParams(Params):
    """Nav2 ``waypoint_follower`` parameters used here."""

    stop_on_failure: bool = True


@dataclass
class _Follow:
    handle: GoalHandle[m.FollowWaypointsGoal]
    names: tuple[str, ...]
    index: int = 0
    nav: GoalHandle[m.NavigateToPoseGoal] | None = None
    missed: list[m.MissedWaypoint] = field(default_factory=list)


class WaypointFollower(Node):
    """FollowWaypoints action server driving the NavigateToPose action."""

    def __init__(self, runtime: Runtime, params: WaypointFollowerParams | None = None,
                 name: str = "waypoint_follower") -> None:
        super().__init__(name, runtime)
        self.params = params or WaypointFollowerParams()
        self._server: ActionServer[m.FollowWaypointsGoal] | None = None
        self._nav: ActionClient[m.NavigateToPoseGoal] = ActionClient(runtime.bus,
                                                                     m.NAVIGATE_TO_POSE)
        self._run: _Follow | None = None

    def on_configure(self) -> None:
        self._server = ActionServer(self.bus, m.FOLLOW_WAYPOINTS, self._on_goal, self._on_cancel)

    def on_deactivate(self) -> None:
        if self._run is not None:
            self._stop(self._run, f"{self.name} was deactivated")

    def on_cleanup(self) -> None:
        if self._server is not None:
            self._server.close()
            self._server = None

    # --- goals -------------------------------------------------------------------------
    def _on_goal(self, handle: GoalHandle[m.FollowWaypointsGoal]) -> bool | str:
        if self.state is not LifecycleState.ACTIVE:
            return f"{self.name} is not active (state {self.state.value}); activate it first"
        goal = handle.goal
        if goal.names and len(goal.names) != len(goal.poses):
            return (f"names has {len(goal.names)} entries for {len(goal.poses)} poses; give "
                    f"one name per pose or none")
        handle.execute()
        if not goal.poses:
            handle.fail(int(FollowWaypointsErrorCode.NO_VALID_WAYPOINTS),
                        "no waypoints given; send at least one pose", m.FollowWaypointsResult())
            return True
        if self._run is not None:
            self._stop(self._run, "preempted by a new goal")
        names = goal.names or tuple(f"waypoint {i}" for i in range(len(goal.poses)))
        run = _Follow(handle, tuple(names))
        self._run = run

        def start() -> None:  # after the client attached its callbacks (submit is synchronous)
            if run is self._run:
                self._send(run)

        self.runtime.scheduler.call_soon(start)
        return True

    def _on_cancel(self, handle: GoalHandle[m.FollowWaypointsGoal]) -> None:
        run = self._run
        if run is not None and run.handle is handle:
            self._stop(run, "canceled on request")
        else:
            handle.canceled()

    def _stop(self, run: _Follow, reason: str) -> None:
        """End ``run`` CANCELED, cancelling its navigation goal."""
        self._run = None
        if run.nav is not None and not run.nav.done:
            run.nav.cancel()
        run.handle.canceled(m.FollowWaypointsResult(tuple(run.missed)), reason=reason)

    def _label(self, run: _Follow) -> str:
        return f"waypoint {run.index} '{run.names[run.index]}'"

    def _send(self, run: _Follow) -> None:
        goal = run.handle.goal
        if run.index >= len(goal.poses):
            self._run = None
            run.handle.succeed(m.FollowWaypointsResult(tuple(run.missed)))
            return
        run.handle.publish_feedback(m.FollowWaypointsFeedback(run.index, run.names[run.index]))
        if not self._nav.server_ready():
            result = ActionResult(GoalStatus.FAILED, int(m.NavigatorErrorCode.UNKNOWN),
                                  f"no NavigateToPose server at '{m.NAVIGATE_TO_POSE}'; start "
                                  f"and activate the bt_navigator")
            self.runtime.scheduler.call_soon(self._on_nav_done, run, None, result)
            return
        nav = self._nav.send_goal(m.NavigateToPoseGoal(goal.poses[run.index]))
        run.nav = nav

        def done(res: ActionResult) -> None:  # answer later, never inside the navigator's tick
            self.runtime.scheduler.call_soon(self._on_nav_done, run, nav, res)

        nav.add_done_callback(done)

    def _on_nav_done(self, run: _Follow, nav: GoalHandle[Any] | None,
                     result: ActionResult) -> None:
        if run is not self._run or nav is not run.nav:
            return  # a stale answer for a stopped or superseded navigation
        if result.status is GoalStatus.SUCCEEDED:
            run.index += 1
            self._send(run)
            return
        label = self._label(run)
        if result.status is GoalStatus.CANCELED:
            self._run = None
            run.handle.canceled(m.FollowWaypointsResult(tuple(run.missed)),
                                reason=f"navigation to {label} was canceled by another "
                                       f"client: {result.error_msg}")
            return
        run.missed.append(m.MissedWaypoint(run.index, run.names[run.index], result.error_code,
                                           result.error_msg))
        if self.params.stop_on_failure:
            self._run = None
            run.handle.fail(int(FollowWaypointsErrorCode.STOP_ON_MISSED_WAYPOINT),
                            f"{label} failed: {result.error_msg}; stopping (stop_on_failure "
                            f"is true)", m.FollowWaypointsResult(tuple(run.missed)))
            return
        self.log.warning("%s missed: %s; continuing", label, result.error_msg)
        run.index += 1
        self._send(run)


# --- YAML ------------------------------------------------------------------------------------
_ENTRY_KEYS = ("name", "position", "orientation", "frame_id")
_TOP_KEYS = ("waypoints", "order")


def _number(value: Any, key: str, file: str, errors: list[ConfigError]) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        errors.append(ConfigError(f"must be a number (got {value!r})", file=file, key_path=key))
        return 0.0
    if not math.isfinite(value):
        errors.append(ConfigError(f"must be a finite number (got {value!r})", file=file,
                                  key_path=key))
        return 0.0
    if abs(value) > MAX_COORDINATE:
        errors.append(ConfigError(f"must be within ±{MAX_COORDINATE:g} m (got {value!r})",
                                  file=file, key_path=key))
        return 0.0
    return float(value)


def _unknown_keys(data: Mapping[str, Any], known: tuple[str, ...], prefix: str, file: str,
                  errors: list[ConfigError]) -> None:
    for key in data:
        if key not in known:
            path = f"{prefix}.{key}" if prefix else str(key)
            errors.append(ConfigError("unknown key", file=file, key_path=path,
                                      suggestion=did_you_mean(str(key), known).strip(" ()")))


def _vector(data: Any, key: str, axes: str, required: str, file: str,
            errors: list[ConfigError]) -> dict[str, float]:
    if not isinstance(data, Mapping):
        errors.append(ConfigError(f"must be a mapping with keys {', '.join(axes)} "
                                  f"(got {data!r})", file=file, key_path=key))
        return {}
    _unknown_keys(data, tuple(axes), key, file, errors)
    for axis in required:
        if axis not in data:
            errors.append(ConfigError("required key is missing", file=file,
                                      key_path=f"{key}.{axis}"))
    return {a: _number(data[a], f"{key}.{a}", file, errors) for a in axes if a in data}


def _waypoint(entry: Any, i: int, file: str, errors: list[ConfigError]
              ) -> tuple[str, PoseStamped] | None:
    key = f"waypoints[{i}]"
    if not isinstance(entry, Mapping):
        errors.append(ConfigError(f"must be a mapping with name, position and orientation "
                                  f"(got {entry!r})", file=file, key_path=key))
        return None
    n = len(errors)
    _unknown_keys(entry, _ENTRY_KEYS, key, file, errors)
    name = entry.get("name")
    if not isinstance(name, str) or not name:
        errors.append(ConfigError(f"must be a non-empty string (got {name!r})" if "name" in entry
                                  else "required key is missing", file=file,
                                  key_path=f"{key}.name"))
    if "position" not in entry:
        errors.append(ConfigError("required key is missing", file=file,
                                  key_path=f"{key}.position"))
    pos = _vector(entry.get("position", {}), f"{key}.position", "xyz", "xy", file, errors) \
        if "position" in entry else {}
    q = _vector(entry["orientation"], f"{key}.orientation", "xyzw", "", file, errors) \
        if "orientation" in entry else {"w": 1.0}
    frame = entry.get("frame_id", "map")
    if not isinstance(frame, str) or not frame:
        errors.append(ConfigError(f"must be a non-empty frame name (got {frame!r})", file=file,
                                  key_path=f"{key}.frame_id"))
    if len(errors) > n:
        return None
    qx, qy, qz, qw = (q.get(a, 0.0) for a in "xyzw")
    norm2 = qx * qx + qy * qy + qz * qz + qw * qw
    if abs(norm2 - 1.0) > QUATERNION_NORMALIZATION_TOLERANCE:
        errors.append(ConfigError(
            f"quaternion is not normalised (|q| = {math.sqrt(norm2):.4f}); use unit length, "
            f"e.g. {{z: 0.7071, w: 0.7071}} for a yaw of 90 degrees", file=file,
            key_path=f"{key}.orientation"))
        return None
    k = 1.0 / math.sqrt(norm2)
    pose = Pose(Point(pos["x"], pos["y"], pos.get("z", 0.0)),
                Quaternion(qx * k, qy * k, qz * k, qw * k))
    return str(name), PoseStamped(Header(0.0, str(frame)), pose)


def load_waypoints(path: str | FsPath) -> list[tuple[str, PoseStamped]]:
    """Read ``waypoints: [{name, position: {x, y, z}, orientation: {x, y, z, w}, frame_id}]``
    and the optional ``order: [names]`` from a YAML file.

    ``position.z`` defaults to 0, a missing ``orientation`` to identity (missing
    components to 0), ``frame_id`` to ``map``.  ``order`` lists names in the order to
    visit (a subset, repeats allowed).  Every problem -- missing or non-numeric values,
    NaN, a non-unit quaternion, duplicate or unknown names, unknown keys -- is reported
    as a :class:`ConfigError` naming the file and key path (several at once as
    :class:`ConfigErrors`).
    """
    file = str(path)
    try:
        data = yaml.safe_load(FsPath(path).read_text())
    except OSError as exc:
        raise ConfigError(f"cannot read the waypoints file: {exc.strerror or exc}",
                          file=file) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ConfigError(f"invalid YAML{where}: {getattr(exc, 'problem', exc)}",
                          file=file) from None
    if not isinstance(data, Mapping) or "waypoints" not in data:
        raise ConfigError("required key is missing (the file needs a top-level 'waypoints' "
                          "list)", file=file, key_path="waypoints")
    errors: list[ConfigError] = []
    _unknown_keys(data, _TOP_KEYS, "", file, errors)
    entries = data["waypoints"]
    if not isinstance(entries, list) or not entries:
        raise ConfigError(f"must be a non-empty list of waypoints (got {entries!r})", file=file,
                          key_path="waypoints")
    waypoints: list[tuple[str, PoseStamped]] = []
    first_index: dict[str, int] = {}
    for i, entry in enumerate(entries):
        wp = _waypoint(entry, i, file, errors)
        if wp is None:
            continue
        if wp[0] in first_index:
            errors.append(ConfigError(f"duplicate name '{wp[0]}' (also waypoints"
                                      f"[{first_index[wp[0]]}])", file=file,
                                      key_path=f"waypoints[{i}].name"))
            continue
        first_index[wp[0]] = i
        waypoints.append(wp)
    order = data.get("order")
    if order is not None:
        raw = {e.get("name") for e in entries if isinstance(e, Mapping)}
        waypoints = _reorder(order, waypoints, raw, file, errors)
    if errors:
        raise errors[0] if len(errors) == 1 else ConfigErrors(errors)
    return waypoints


def _reorder(order: Any, waypoints: list[tuple[str, PoseStamped]], raw_names: set[Any],
             file: str, errors: list[ConfigError]) -> list[tuple[str, PoseStamped]]:
    """Waypoints in ``order``; names of malformed entries (already reported) are skipped."""
    if not isinstance(order, list) or not order:
        errors.append(ConfigError(f"must be a non-empty list of waypoint names (got {order!r})",
                                  file=file, key_path="order"))
        return waypoints
    by_name = dict(waypoints)
    out: list[tuple[str, PoseStamped]] = []
    for j, name in enumerate(order):
        if isinstance(name, str) and name in by_name:
            out.append((name, by_name[name]))
            continue
        if isinstance(name, str) and name in raw_names:
            continue
        hint = did_you_mean(str(name), by_name).strip(" ()")
        errors.append(ConfigError(f"unknown waypoint {name!r}; known: {', '.join(by_name)}",
                                  file=file, key_path=f"order[{j}]", suggestion=hint))
    return out

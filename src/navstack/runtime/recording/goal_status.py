"""``action_msgs`` equivalents: the status of navigation goals in a recording.

ROS 2 actions publish ``<action>/_action/status`` (``action_msgs/msg/GoalStatusArray``);
a rosbag2 recording of a Nav2 system therefore holds
``/navigate_to_pose/_action/status``, and that is what :class:`BagRecorder` writes for the
in-process ``/navigate_to_pose`` action (our actions have no bus topic).  The report
reads it to split a run into goals.  Status codes are action_msgs' own.
"""

from __future__ import annotations

from dataclasses import dataclass

from navstack.runtime.actions import GoalStatus as ActionStatus

STATUS_UNKNOWN = 0
STATUS_ACCEPTED = 1
STATUS_EXECUTING = 2
STATUS_CANCELING = 3
STATUS_SUCCEEDED = 4
STATUS_CANCELED = 5
STATUS_ABORTED = 6

#: action_msgs status code of each in-process goal status (REJECTED goals never get a
#: status in ROS 2: the server refuses them before they exist).
STATUS_CODES: dict[ActionStatus, int] = {
    ActionStatus.ACCEPTED: STATUS_ACCEPTED, ActionStatus.EXECUTING: STATUS_EXECUTING,
    ActionStatus.CANCELING: STATUS_CANCELING, ActionStatus.SUCCEEDED: STATUS_SUCCEEDED,
    ActionStatus.CANCELED: STATUS_CANCELED, ActionStatus.FAILED: STATUS_ABORTED,
}

STATUS_NAMES: dict[int, str] = {
    STATUS_UNKNOWN: "UNKNOWN", STATUS_ACCEPTED: "ACCEPTED", STATUS_EXECUTING: "EXECUTING",
    STATUS_CANCELING: "CANCELING", STATUS_SUCCEEDED: "SUCCEEDED", STATUS_CANCELED: "CANCELED",
    STATUS_ABORTED: "ABORTED",
}

TERMINAL = frozenset((STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED))


def goal_uuid(goal_id: int) -> bytes:
    """The 16-byte ``unique_identifier_msgs/UUID`` of an in-process goal number."""
    return int(goal_id).to_bytes(16, "big")


@dataclass(frozen=True, slots=True)
class GoalInfo:
    """action_msgs/GoalInfo: ``goal_id`` (16 bytes) and ``stamp`` (acceptance time [s])."""

    goal_id: bytes = bytes(16)
    stamp: float = 0.0


@dataclass(frozen=True, slots=True)
class GoalStatusEntry:
    """action_msgs/GoalStatus (named so it does not clash with the runtime's enum)."""

    goal_info: GoalInfo = GoalInfo()
    status: int = STATUS_UNKNOWN

    @property
    def terminal(self) -> bool:
        return self.status in TERMINAL


@dataclass(frozen=True, slots=True)
class GoalStatusArray:
    """action_msgs/GoalStatusArray."""

    status_list: tuple[GoalStatusEntry, ...] = ()

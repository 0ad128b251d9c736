"""Navigation action and service interfaces: names, goals, feedback, results, error codes.

Shaped after nav2_msgs (ComputePathToPose, FollowPath, NavigateToPose,
NavigateThroughPoses, FollowWaypoints, Spin, BackUp, DriveOnHeading, Wait).  Error codes
keep Nav2's numbering where Nav2 has one so Nav2 users recognise them; every non-zero
code travels with a human-readable reason in ``ActionResult.error_msg``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

from navstack.core.msgs import Path, Pose2D, PoseStamped

# --- action and service names (Nav2 defaults) --------------------------------------------
COMPUTE_PATH_TO_POSE = "/compute_path_to_pose"
FOLLOW_PATH = "/follow_path"
NAVIGATE_TO_POSE = "/navigate_to_pose"
NAVIGATE_THROUGH_POSES = "/navigate_through_poses"
FOLLOW_WAYPOINTS = "/follow_waypoints"
SPIN = "/spin"
BACKUP = "/backup"
DRIVE_ON_HEADING = "/drive_on_heading"
WAIT = "/wait"
CLEAR_GLOBAL_COSTMAP = "/global_costmap/clear_entirely_global_costmap"
CLEAR_LOCAL_COSTMAP = "/local_costmap/clear_entirely_local_costmap"
CLEAR_AROUND_LOCAL_COSTMAP = "/local_costmap/clear_around_local_costmap"
IS_PATH_VALID = "/is_path_valid"


class PlannerErrorCode(IntEnum):
    """nav2_msgs/ComputePathToPose error codes."""

    NONE = 0
    UNKNOWN = 200
    INVALID_PLANNER = 201
    TF_ERROR = 202
    START_OUTSIDE_MAP = 203
    GOAL_OUTSIDE_MAP = 204
    START_OCCUPIED = 205
    GOAL_OCCUPIED = 206
    TIMEOUT = 207
    NO_VALID_PATH = 208
    CANCELLED = 209


class ControllerErrorCode(IntEnum):
    """nav2_msgs/FollowPath error codes."""

    NONE = 0
    UNKNOWN = 100
    INVALID_CONTROLLER = 101
    TF_ERROR = 102
    INVALID_PATH = 103
    PATIENCE_EXCEEDED = 104
    FAILED_TO_MAKE_PROGRESS = 105
    NO_VALID_CONTROL = 106


class BehaviorErrorCode(IntEnum):
    """Error codes of spin / backup / drive_on_heading / wait (nav2 behaviors)."""

    NONE = 0
    UNKNOWN = 700
    TIMEOUT = 701
    TF_ERROR = 702
    COLLISION_AHEAD = 703
    INVALID_INPUT = 704


class NavigatorErrorCode(IntEnum):
    """NavigateToPose / NavigateThroughPoses / FollowWaypoints error codes."""

    NONE = 0
    UNKNOWN = 9000
    INVALID_GOAL = 9001
    TF_ERROR = 9002
    TIMEOUT = 9003
    GOAL_OUTSIDE_MAP = 9004
    GOAL_OCCUPIED = 9005
    NO_VALID_PATH = 9006
    RECOVERIES_EXHAUSTED = 9007
    NO_PROGRESS = 9008
    CANCELED = 9009


# --- planner / controller ----------------------------------------------------------------
@dataclass(frozen=True)
class ComputePathToPoseGoal:
    goal: PoseStamped
    start: PoseStamped | None = None  # None: use the robot's current pose
    planner_id: str = ""


@dataclass(frozen=True)
class FollowPathGoal:
    path: Path
    controller_id: str = ""
    goal_checker_id: str = ""


@dataclass(frozen=True)
class FollowPathFeedback:
    distance_to_goal: float
    speed: float


# --- behaviors -------------------------------------------------------------------------
@dataclass(frozen=True)
class SpinGoal:
    target_yaw: float  # relative angle to turn [rad], sign = direction
    time_allowance: float = 10.0


@dataclass(frozen=True)
class BackUpGoal:
    distance: float = 0.30  # metres to drive backwards (positive)
    speed: float = 0.05
    time_allowance: float = 10.0


@dataclass(frozen=True)
class DriveOnHeadingGoal:
    distance: float = 0.30  # metres along the current heading (sign = direction)
    speed: float = 0.05
    time_allowance: float = 10.0


@dataclass(frozen=True)
class WaitGoal:
    time: float = 5.0


@dataclass(frozen=True)
class BehaviorFeedback:
    """Progress of a behavior: angle turned [rad], distance travelled [m] or time left [s]."""

    progress: float


# --- navigators --------------------------------------------------------------------------
@dataclass(frozen=True)
class NavigateToPoseGoal:
    pose: PoseStamped
    behavior_tree: str = ""


@dataclass(frozen=True)
class NavigateThroughPosesGoal:
    poses: tuple[PoseStamped, ...]
    behavior_tree: str = ""


@dataclass(frozen=True)
class FollowWaypointsGoal:
    poses: tuple[PoseStamped, ...]
    names: tuple[str, ...] = ()


@dataclass(frozen=True)
class NavigateFeedback:
    """Feedback of NavigateToPose / NavigateThroughPoses (nav2_msgs field names)."""

    current_pose: Pose2D
    navigation_time: float
    estimated_time_remaining: float
    number_of_recoveries: int
    distance_remaining: float
    number_of_poses_remaining: int = 0
    paused_reason: str = ""
    """navstack addition: why navigation is on hold (``""`` while it runs), e.g. "link
    lost: ..." from a vehicle driver (``/navigation/hold``)."""


@dataclass(frozen=True)
class FollowWaypointsFeedback:
    current_waypoint: int
    current_waypoint_name: str = ""


@dataclass(frozen=True)
class MissedWaypoint:
    index: int
    name: str
    error_code: int
    error_msg: str


@dataclass(frozen=True)
class FollowWaypointsResult:
    missed_waypoints: tuple[MissedWaypoint, ...] = field(default_factory=tuple)

"""Recording, replay and import of ROS bags (rosbag2 MCAP/sqlite3, ROS 1) via rosbags.

* :class:`BagRecorder` -- bus topics into a rosbag2 folder (MCAP, CDR), ``ros2 bag record``
* :class:`BagPlayer` -- a bag onto a bus in log-time order on the scheduler clock
* :class:`BagReader` -- any ROS 1 / ROS 2 bag as navstack messages
* :func:`import_bag` -- a ROS 1 / ROS 2 bag into a navstack rosbag2 (MCAP)
* :class:`RosCodec` -- navstack message <-> ROS 2 message / CDR bytes
"""

from navstack.runtime.recording.convert import RosCodec, supported_ros_types
from navstack.runtime.recording.errors import (
    BagError,
    BagExistsError,
    BagFormatError,
    BagNotFoundError,
    UnsupportedTypeError,
)
from navstack.runtime.recording.goal_status import GoalInfo, GoalStatusArray, GoalStatusEntry
from navstack.runtime.recording.importer import ImportResult, import_bag
from navstack.runtime.recording.player import BagPlayer, runtime_for_bag
from navstack.runtime.recording.reader import BagMessage, BagReader, TopicSummary
from navstack.runtime.recording.recorder import DEFAULT_TOPICS, BagRecorder
from navstack.runtime.recording.writer import BagSummary, BagWriter

__all__ = [
    "DEFAULT_TOPICS", "BagError", "BagExistsError", "BagFormatError", "BagMessage",
    "BagNotFoundError", "BagPlayer", "BagReader", "BagRecorder", "BagSummary", "BagWriter",
    "GoalInfo", "GoalStatusArray", "GoalStatusEntry", "ImportResult", "RosCodec",
    "TopicSummary", "UnsupportedTypeError", "import_bag", "runtime_for_bag",
    "supported_ros_types",
]

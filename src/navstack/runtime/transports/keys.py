"""Key expressions of navstack entities on Zenoh, after rmw_zenoh's documented scheme.

rmw_zenoh (ros2/rmw_zenoh, docs/design.md) puts a topic's data on
``<domain_id>/<fully qualified name without the leading slash>/<DDS type name>/<type hash>``
-- e.g. ``0/robot1/scan/sensor_msgs::msg::dds_::LaserScan_/RIHS01_<sha256>`` -- and announces
every entity with a liveliness token
``@ros2_lv/<domain_id>/<zid>/<nid>/<eid>/<kind>/<enclave>/<namespace>/<node>/<name>/<type>/<hash>/<qos>``
whose name parts have ``/`` replaced by ``%`` (``%`` alone = empty).  navstack uses the
same layout for topics, so a ROS 2 node on rmw_zenoh subscribing to ``/robot1/scan`` in
domain 0 matches navstack's key; the type hash is rosbags' RIHS01 hash of the Humble
definition.  Services, actions and the clock exchange are navstack-specific and live under
``<domain_id>/@navstack/...`` (a verbatim chunk, never matched by ROS wildcards).
"""

from __future__ import annotations

from functools import lru_cache

from navstack.core.errors import ConfigError


def dds_type_name(ros_type: str) -> str:
    """``sensor_msgs/msg/LaserScan`` -> ``sensor_msgs::msg::dds_::LaserScan_`` (rmw_zenoh)."""
    parts = ros_type.split("/")
    if len(parts) != 3 or not all(parts):
        raise ConfigError(f"ROS type name '{ros_type}' is not 'package/msg/Name'")
    pkg, kind, name = parts
    return f"{pkg}::{kind}::dds_::{name}_"


@lru_cache(maxsize=256)
def type_hash(ros_type: str) -> str:
    """RIHS01 type hash of a Humble type (navstack's typestore, nav2 types included)."""
    from navstack.runtime.recording.convert import humble_typestore

    return str(humble_typestore().hash_rihs01(ros_type))


def check_name(name: str, what: str = "topic") -> str:
    """A fully qualified ROS name (``/a/b``): leading slash added, no empty or wildcard
    segments."""
    full = name if name.startswith("/") else "/" + name
    segments = full[1:].split("/")
    if not full[1:] or any(not s or s in ("*", "**") or "$" in s or "#" in s or "?" in s
                           for s in segments):
        raise ConfigError(f"{what} name '{name}' is not a valid ROS name (segments of "
                          f"letters, digits and '_' separated by '/')")
    return full


def namespaced(namespace: str, name: str) -> str:
    """``/robot1`` + ``/scan`` -> ``/robot1/scan`` (empty namespace: the name itself)."""
    name = check_name(name)
    ns = namespace.strip("/")
    return f"/{ns}{name}" if ns else name


def topic_key(domain_id: int, full_name: str, ros_type: str) -> str:
    """The rmw_zenoh data key of a topic."""
    name = check_name(full_name)[1:]
    return f"{domain_id}/{name}/{dds_type_name(ros_type)}/{type_hash(ros_type)}"


def mangle(name: str) -> str:
    """rmw_zenoh's liveliness spelling of a name: ``/`` -> ``%`` (empty -> ``%``)."""
    return name.replace("/", "%") if name else "%"


def liveliness_token(domain_id: int, zid: str, node_id: int, entity_id: int, kind: str,
                     namespace: str, node: str, full_name: str = "", ros_type: str = "",
                     qos: str = "") -> str:
    """A liveliness key in rmw_zenoh's layout; ``kind`` is ``NN`` (node), ``MP``
    (publisher), ``MS`` (subscription), ``SS`` (service server) or ``SC`` (client)."""
    parts = ["@ros2_lv", str(domain_id), zid, str(node_id), str(entity_id), kind, "%",
             mangle(namespace), node]
    if full_name:
        parts += [mangle(full_name), dds_type_name(ros_type) if ros_type else "%",
                  type_hash(ros_type) if ros_type else "%", qos or "%"]
    return "/".join(parts)


def qos_string(depth: int, latched: bool) -> str:
    """The QoS part of a liveliness token: ``reliability:durability:history,depth``
    (ROS enum values: reliable=1, transient_local=1 / volatile=2, keep_last=1)."""
    return f"1:{1 if latched else 2}:1,{depth}"


def navstack_key(domain_id: int, *parts: str) -> str:
    """A navstack-only key (services, actions, clock exchange, latched stores)."""
    rest = "/".join(p.strip("/") for p in parts if p.strip("/"))
    return f"{domain_id}/@navstack/{rest}"

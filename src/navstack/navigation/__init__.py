"""navstack.navigation: the orchestration layer (Nav2 bt_navigator, behaviors, waypoints).

* :mod:`.messages` -- action/service names, goals, feedback, error codes (nav2_msgs shape).
* :mod:`.bt_navigator` -- ``BtNavigator``: NavigateToPose / NavigateThroughPoses servers.
* :mod:`.trees` -- the default trees (``*_w_replanning_and_recovery``) as Python builders.
* :mod:`.bt_nodes`, :mod:`.bt_composites` -- py_trees leaves and Nav2 control nodes.
* :mod:`.behavior_server` -- spin / backup / drive_on_heading / wait.
* :mod:`.waypoint_follower` -- FollowWaypoints and ``load_waypoints``.
* :mod:`.map_server`, :mod:`.costmap_node` -- map and costmap nodes.

Submodules are imported explicitly (``from navstack.navigation.bt_navigator import
BtNavigator``) so importing the package does not pull in py_trees.
"""

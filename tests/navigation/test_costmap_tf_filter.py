"""Costmap scans behind a TF message filter (obstacle layer ``tf_message_filter``): a scan
stamped at the instant of an odometry sample that is not delivered yet waits for it
instead of being dropped."""

from __future__ import annotations

import yaml

from navstack.interfaces.stack import NavStack, default_nav2_params_path


def _stack(tf_filter: bool) -> NavStack:
    nav = yaml.safe_load(default_nav2_params_path().read_text())
    for name in ("global_costmap", "local_costmap"):
        nav[name][name]["ros__parameters"]["obstacle_layer"]["tf_message_filter"] = tf_filter
    return NavStack("warehouse", "diff_drive", nav, seed=1).start()


def test_every_scan_reaches_the_costmaps_with_the_filter():
    stack = _stack(True)
    stack.run_for(10.0)
    for costmap in (stack.global_costmap, stack.local_costmap):
        assert costmap.tf_failures == 0, costmap.last_tf_error
        (flt,) = costmap._scan_filters
        assert flt.received >= 100  # 10 Hz for 10 s
        # none lost: all released but the last one, which waits for its odometry
        assert flt.released + len(flt.pending) == flt.received and len(flt.pending) <= 1
        assert flt.dropped == 0


def test_without_the_filter_scans_of_a_pending_instant_are_dropped_and_counted():
    stack = _stack(False)
    stack.run_for(10.0)
    costmap = stack.global_costmap
    assert not costmap._scan_filters
    assert costmap.tf_failures > 10  # the failure the filter removes
    assert "would extrapolate into the future" in costmap.last_tf_error


def test_the_turtlebot3_local_costmap_gets_every_scan():
    """The TurtleBot3 file (ROBOTIS' layout, its own local costmap section) keeps the
    filter too: without it the office explore_lite seed 5 run lost every scan for its
    last 235 s once the timers' order flipped and re-applied the last one at a pose 0.4 m
    back -- a phantom wall beside the robot that ended the return home."""
    from navstack.interfaces.mission_catalog import default_nav2_params

    path = default_nav2_params("turtlebot3_waffle_pi")
    assert path is not None
    stack = NavStack("office", "turtlebot3_waffle_pi", str(path), seed=1).start()
    stack.run_for(10.0)
    costmap = stack.local_costmap
    assert costmap.tf_failures == 0, costmap.last_tf_error
    (flt,) = costmap._scan_filters
    assert flt.received >= 45  # the LDS at 5 Hz for 10 s
    assert flt.dropped == 0 and len(flt.pending) <= 1

"""SlamNode on the simulator: mapping accuracy, map -> odom, serialization, localization."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navstack.core.map_files import load_map
from navstack.core.msgs import OccupancyGrid, Twist
from navstack.mapping.occupancy import free_thresh_after
from navstack.mapping.slam_params import SlamParams
from navstack.nodes.slam import SlamNode, pad_to_extent
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.open_loop import build_sim

SPAWN = (1.0, 7.5, 0.0)  # office corridor, facing east


def _slam_sim(params: dict | None = None, seed: int = 2) -> tuple[Runtime, SimulatorNode,
                                                               SlamNode, list]:
    """Simulator + SLAM node; the robot drives east along the corridor at 0.4 m/s."""
    rt, sim = build_sim("office", "diff_drive", seed, perfect_localization=False)
    slam = SlamNode(rt, SlamParams.from_mapping({"map_start_pose": list(SPAWN),
                                                 **(params or {})}))
    command = [Twist.planar(0.4, 0.0, 0.0)]
    pub = rt.bus.publisher("/cmd_vel", Twist)
    rt.scheduler.create_timer(0.05, lambda: pub.publish(command[0]), first_at=0.0)
    rt.bring_up()
    return rt, sim, slam, command


def _pose_error(sim: SimulatorNode, slam: SlamNode, rt: Runtime) -> float:
    odom = rt.tf.lookup_pose2d("odom", "base_link")
    assert slam.mapper is not None
    est = slam.mapper.pose_of(np.array([odom.x, odom.y, odom.theta]))
    true = sim.sim.pose
    return math.hypot(est[0] - true.x, est[1] - true.y)


def test_mapping_the_corridor_tracks_the_true_pose_and_publishes_map_and_tf() -> None:
    rt, sim, slam, _ = _slam_sim()
    maps: list[OccupancyGrid] = []
    rt.bus.subscribe("/map", OccupancyGrid, maps.append)
    rt.scheduler.run_until(30.0)
    sim.advance()
    assert slam.mapper is not None and slam.mapper.stats.scans_processed >= 20
    assert slam.tf_failures == 0
    assert _pose_error(sim, slam, rt) < 0.05  # odometry alone drifts more (checked below)
    assert maps, "no /map published"
    assert maps[-1].header.frame_id == "map"
    # map -> odom is on TF and agrees with the mapper
    m2o = rt.tf.lookup_pose2d("map", "odom")
    np.testing.assert_allclose([m2o.x, m2o.y], slam.map_to_odom[:2], atol=1e-9)


def test_serialized_graph_reloads_and_continues_without_a_jump(tmp_path: Path) -> None:
    """Acceptance 4: reload a saved graph, keep mapping: no jump at the reload, and the
    session goes on as if it had never been saved (map -> odom within a fifth of a cell
    of an identical run without the reload).  map -> odom itself keeps moving by the
    odometry's own drift (1% scale error: 4 cm over the 4 m driven after the reload)."""
    ref_rt, _, ref_slam, _ = _slam_sim()
    ref_rt.scheduler.run_until(25.0)
    rt, sim, slam, _ = _slam_sim()
    rt.scheduler.run_until(15.0)
    nodes_before = len(slam.mapper.nodes)
    reply = rt.bus.call("/slam_toolbox/serialize_map",
                                {"filename": str(tmp_path / "office")})
    assert reply["result"] and Path(reply["path"]).name == "office.posegraph"
    before = slam.map_to_odom
    reply = rt.bus.call("/slam_toolbox/deserialize_pose_graph",
                                {"filename": reply["path"], "match_type": "continue"})
    assert reply == {"result": True, "nodes": nodes_before}
    after_load = slam.map_to_odom
    rt.scheduler.run_until(25.0)
    sim.advance()
    cell = slam.params.resolution
    assert math.hypot(*(after_load[:2] - before[:2])) < 1e-12
    # the scans after the reload are matched against the reloaded graph
    assert math.hypot(*(slam.map_to_odom[:2] - ref_slam.map_to_odom[:2])) <= 0.2 * cell
    assert len(slam.mapper.nodes) > nodes_before + 5
    assert _pose_error(sim, slam, rt) < 0.05


def test_localization_mode_corrects_a_wrong_initial_pose(tmp_path: Path) -> None:
    rt, _, slam, _ = _slam_sim()
    rt.scheduler.run_until(20.0)
    path = rt.bus.call("/slam_toolbox/serialize_map",
                               {"filename": str(tmp_path / "corridor")})["path"]
    # a second robot run: fresh odometry, started at the spawn, told a pose 0.15 m off
    rt2, sim2, slam2, _ = _slam_sim(seed=5)
    slam2.load(path, match_type="localize", initial_pose=(SPAWN[0] + 0.15, SPAWN[1] - 0.1,
                                                          SPAWN[2] + 0.05))
    rt2.scheduler.run_until(8.0)
    sim2.advance()
    assert slam2.mapper is not None and slam2.mapper.params.mode == "localization"
    assert len(slam2.mapper.nodes) == len(slam.mapper.nodes)  # the map graph is frozen
    assert _pose_error(sim2, slam2, rt2) < 0.05


def test_deserialize_refuses_bad_requests(tmp_path: Path) -> None:
    rt, _, slam, _ = _slam_sim()
    reply = rt.bus.call("/slam_toolbox/deserialize_pose_graph",
                                {"filename": "x", "match_type": "teleport"})
    assert reply == {"result": False,
                     "reason": "match_type 'teleport': use 'continue' or 'localize'"}
    from navstack.mapping.slam_io import PoseGraphFileError
    with pytest.raises(PoseGraphFileError, match="no such pose graph file"):
        slam.load(tmp_path / "missing.posegraph")


def test_published_and_saved_maps_show_free_space_after_map_free_scans_scans(
        tmp_path: Path) -> None:
    """Free space appears after ``map_free_scans`` node scans (2, Karto-like), not the
    four map_server's 0.196 would need; occupied cells do not depend on it."""
    grids = {}
    for n in (2, 4):
        rt, _, slam, _ = _slam_sim({"map_free_scans": n})
        rt.scheduler.run_until(3.0)
        assert slam.mapper is not None and 3 <= len(slam.mapper.nodes) <= 5
        grid = slam.occupancy_grid()
        assert grid is not None
        expected = slam.mapper.live_map().to_occupancy_grid(
            crop=True, free_thresh=free_thresh_after(n))
        np.testing.assert_array_equal(grid.data, expected.data)
        grids[n] = grid.data
        if n == 2:
            reply = rt.bus.call("/slam_toolbox/save_map", {"name": str(tmp_path / "m")})
            assert reply["result"]
            assert "free_thresh: 0.196" in (tmp_path / "m.yaml").read_text()
            saved = load_map(tmp_path / "m.yaml")
            np.testing.assert_array_equal(
                saved.data, slam.mapper.build_map().to_occupancy_grid(
                    crop=True, free_thresh=free_thresh_after(2)).data)
    assert np.count_nonzero(grids[2] == 0) > 1.3 * np.count_nonzero(grids[4] == 0)
    np.testing.assert_array_equal(grids[2] == 100, grids[4] == 100)


def test_asynchronous_mode_processes_scans_off_the_callback() -> None:
    rt, sim, slam, _ = _slam_sim({"synchronous": False})
    for t in np.arange(1.0, 12.0, 1.0):
        rt.scheduler.run_until(float(t))
        slam.wait_idle()
    sim.advance()
    assert slam.mapper is not None and slam.mapper.stats.scans_processed >= 5
    assert _pose_error(sim, slam, rt) < 0.1


def test_pad_to_extent_grows_with_unknown_cells_and_keeps_alignment() -> None:
    from dataclasses import replace

    from navstack.core.msgs import MapMetaData, Point, Pose

    info = MapMetaData(resolution=0.5, width=2, height=1, origin=Pose(Point(1.0, 1.0, 0.0)))
    grid = replace(OccupancyGrid(), info=info, data=np.array([[0, 100]], np.int8))
    padded = pad_to_extent(grid, [0.0, 0.0, 2.5, 2.0])
    assert (padded.info.width, padded.info.height) == (5, 4)
    assert (padded.info.origin.position.x, padded.info.origin.position.y) == (0.0, 0.0)
    np.testing.assert_array_equal(padded.data[2], [-1, -1, 0, 100, -1])
    assert (padded.data[[0, 1, 3]] == -1).all()


def test_a_mapper_exception_loses_one_scan_not_the_session(
        caplog: pytest.LogCaptureFixture) -> None:
    """A bug inside the mapper on one scan is counted, named and logged; the node keeps
    mapping the following scans and the pose stays right."""
    rt, sim, slam, _ = _slam_sim()
    rt.scheduler.run_until(2.0)
    assert slam.mapper is not None
    real = slam.mapper.process_scan
    calls = [0]

    def flaky(*args: object, **kwargs: object) -> bool:
        calls[0] += 1
        if calls[0] == 3:
            raise ValueError("PrecomputedGrids needs at least one point")
        return real(*args, **kwargs)  # type: ignore[arg-type]

    slam.mapper.process_scan = flaky  # type: ignore[method-assign]
    nodes_before = len(slam.mapper.nodes)
    with caplog.at_level("ERROR"):
        rt.scheduler.run_until(20.0)
    sim.advance()
    assert slam.scans_failed == 1
    assert slam.last_problem.endswith(
        "not mapped: ValueError: PrecomputedGrids needs at least one point")
    assert "PrecomputedGrids" in caplog.text and "Traceback" in caplog.text
    assert len(slam.mapper.nodes) > nodes_before + 5
    assert _pose_error(sim, slam, rt) < 0.05

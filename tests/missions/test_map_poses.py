"""Map by visiting chosen poses (issue 16 acceptance 4, on the arena for CI; the office
with the Nav2-lab pose list runs in `navstack mission map-poses --world office`): the map
is saved as map_server files and a pose graph, reloaded by map_server and by SLAM in
localization mode, and the completeness after every pose is reported."""

from __future__ import annotations

from pathlib import Path

from navstack.core.map_files import load_map
from navstack.interfaces.mission_catalog import MissionOptions
from navstack.interfaces.mission_run import run_mission

POSES = """
waypoints:
  - {name: Centre, position: {x: 2.0, y: 1.9}, orientation: {z: 0.0, w: 1.0}}
  - {name: NorthEast, position: {x: 3.3, y: 3.3}, orientation: {z: 0.0, w: 1.0}}
  - {name: Unused, position: {x: 0.7, y: 3.3}, orientation: {z: 0.0, w: 1.0}}
order: [Centre, NorthEast]
"""


def test_map_poses_saves_reloads_and_reports_completeness(tmp_path: Path) -> None:
    poses = tmp_path / "poses.yaml"
    poses.write_text(POSES)
    out = tmp_path / "out"
    r = run_mission("map-poses", out, "arena", "turtlebot3_waffle_pi", 1,
                    options=MissionOptions(poses=poses, max_duration=300.0),
                    show_progress=False)
    assert r["status"] == "SUCCEEDED", r["reason"]
    visited = r["map_poses"]["poses"]
    assert [p["name"] for p in visited] == ["Centre", "NorthEast"]
    assert all(p["status"] == "REACHED" for p in visited)
    # completeness grows pose by pose and ends high in the small arena
    after = [p["completeness_after"] for p in visited]
    assert after == sorted(after) and after[-1] >= 0.9 and r["completeness"] >= 0.9
    saved = r["map_poses"]["saved"]
    assert Path(saved["map_yaml"]) == out / "map.yaml" and (out / "map.pgm").is_file()
    assert Path(saved["posegraph"]) == out / "map.posegraph"
    grid = load_map(saved["map_yaml"])
    assert grid.info.resolution == 0.05
    reload = r["reload"]
    assert reload["map_server_cells_agree"] >= 0.99
    assert reload["map_server_goal"] == "SUCCEEDED" and reload["map_server_ok"]
    assert reload["slam_localization_goal"] == "SUCCEEDED" and reload["slam_localization_ok"]
    assert reload["slam_localization_error_m"] <= 0.15
    assert r["success"]
    assert "| Centre | REACHED |" in (out / "report.md").read_text()

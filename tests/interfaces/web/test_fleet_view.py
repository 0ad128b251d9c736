"""The dashboard's fleet view: every robot of a running fleet on one page."""

from __future__ import annotations

import math

import httpx
import pytest

from navstack.interfaces.fleet import Fleet, load_fleet
from navstack.interfaces.fleet_mission import FleetMission
from navstack.interfaces.web.fleet_view import FleetView, FleetViewError, serve_fleet_view


@pytest.fixture(scope="module")
def served():
    mission = FleetMission(Fleet(load_fleet(), robots=3))
    view = FleetView(mission)
    handle = serve_fleet_view(view, port=0)
    while mission.fleet.now < 3.0:  # every robot has a plan and has started to move
        mission.step()
        view.update()
    yield mission, view, handle
    handle.stop()


def test_snapshot_shows_every_robot_where_it_is(served):
    mission, _, handle = served
    snap = httpx.get(f"{handle.url}api/fleet", timeout=10.0).json()
    assert snap["fleet"] == "warehouse_fleet" and snap["done"] is False
    assert snap["time"] == pytest.approx(mission.fleet.now, abs=0.01)
    assert [r["name"] for r in snap["robots"]] == ["robot1", "robot2", "robot3"]
    for r in snap["robots"]:
        p = mission.fleet.physics.sim(r["name"]).pose
        assert r["pose"][:2] == pytest.approx([p.x, p.y], abs=1e-3)
        route = mission.runs[r["name"]].spec.route
        assert r["goal"] == route[0].name and r["total"] == len(route)
        end = r["path"][-1]  # the robot's own plan, ending at its own first goal
        assert math.hypot(end[0] - route[0].pose[0], end[1] - route[0].pose[1]) < 0.05
        assert len(r["trail"]) >= 20 and r["distance_remaining"] > 1.0
        assert r["collisions"] == 0
    assert snap["map"]["width"] == 800 and snap["map"]["resolution"] == 0.05


def test_page_and_map_are_served(served):
    _, view, handle = served
    page = httpx.get(handle.url, timeout=10.0)
    assert page.status_code == 200 and '<canvas id="map">' in page.text
    png = httpx.get(f"{handle.url}api/fleet/map.png", timeout=10.0)
    assert png.headers["content-type"] == "image/png"
    assert png.content[:8] == b"\x89PNG\r\n\x1a\n" and png.content == view.map_png


def test_port_in_use_is_a_clear_error(served):
    _, view, handle = served
    with pytest.raises(FleetViewError, match=f"cannot listen on 127.0.0.1:{handle.port}"):
        serve_fleet_view(view, port=handle.port)

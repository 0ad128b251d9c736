"""World building (primitives, map files), moving obstacles, and the built-in worlds."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from navstack.core.errors import ConfigError, MapFileError, UnknownNameError
from navstack.core.map_files import save_map
from navstack.sim.collision import clearance, grid_clearance
from navstack.sim.world import MovingObstacle, World
from navstack.sim.world_io import world_from_mapping
from navstack.sim.worlds import list_worlds, load_world, world_path


def build(**spec: object) -> World:
    base: dict[str, object] = {"resolution": 0.05, "size": [2.0, 1.0], "boundary": False,
                               "spawn": {"x": 0.2, "y": 0.2}}
    base.update(spec)
    return world_from_mapping(base, "test.yaml")


def cells(world: World) -> set[tuple[int, int]]:
    return {(int(r), int(c)) for r, c in np.argwhere(world.occupied)}


# --- rasterisation --------------------------------------------------------------------
def test_wall_occupies_exactly_its_cells() -> None:
    w = build(walls=[{"from": [0.5, 0.5], "to": [1.5, 0.5], "thickness": 0.1}])
    assert w.occupied.shape == (20, 40)
    # y in [0.45, 0.55] -> rows 9, 10; x in [0.5, 1.5] -> cols 10..29
    assert cells(w) == {(r, c) for r in (9, 10) for c in range(10, 30)}


def test_vertical_wall_and_origin_offset() -> None:
    w = build(origin=[-1.0, -0.5], walls=[{"from": [0.0, -0.5], "to": [0.0, 0.25],
                                           "thickness": 0.2}])
    # x in [-0.1, 0.1] -> cols 18..21; y in [-0.5, 0.25] -> rows 0..14
    assert cells(w) == {(r, c) for r in range(15) for c in range(18, 22)}
    assert w.bounds == (-1.0, -0.5, 1.0, 0.5)


def test_thin_diagonal_wall_has_no_holes() -> None:
    w = build(walls=[{"from": [0.1, 0.1], "to": [1.9, 0.9], "thickness": 0.001}])
    _, n = ndimage.label(w.occupied, structure=np.ones((3, 3)))
    assert n == 1
    assert w.occupied[2, 2] and w.occupied[17, 37]


def test_box_rotation_and_circle() -> None:
    a = build(boxes=[{"center": [1.0, 0.5], "size": [0.4, 0.2], "yaw": math.pi / 2}])
    b = build(boxes=[{"center": [1.0, 0.5], "size": [0.2, 0.4]}])
    np.testing.assert_array_equal(a.occupied, b.occupied)
    assert cells(b) == {(r, c) for r in range(6, 14) for c in range(18, 22)}
    c = build(circles=[{"center": [1.0, 0.5], "radius": 0.2}])
    ys, xs = np.mgrid[0:20, 0:40]
    inside = ((xs + 0.5) * 0.05 - 1.0) ** 2 + ((ys + 0.5) * 0.05 - 0.5) ** 2 <= 0.04
    np.testing.assert_array_equal(c.occupied, inside)


def test_polygon_and_boundary() -> None:
    w = build(boundary=True, boundary_thickness=0.1,
              polygons=[{"points": [[0.5, 0.2], [1.5, 0.2], [1.0, 0.8]]}])
    occ = w.occupied
    assert occ[:2].all() and occ[-2:].all() and occ[:, :2].all() and occ[:, -2:].all()
    assert not occ[2:-2, 2:-2][:, :6].any()
    # triangle: centre (1.025, 0.225) inside, (0.525, 0.775) outside
    assert occ[4, 20] and not occ[15, 10]
    # near the apex: (1.025, 0.725) is inside, (1.025, 0.775) just outside
    assert occ[14, 20] and not occ[15, 20]


def test_unknown_keys_name_file_path_and_suggestion() -> None:
    with pytest.raises(ConfigError) as err:
        build(walls=[{"from": [0, 0], "to": [1, 0], "thicknes": 0.1}])
    assert str(err.value) == ("test.yaml: walls[0].thicknes: unknown key "
                              "(did you mean 'thickness'?)")
    with pytest.raises(ConfigError) as err:
        build(boundry=True)
    assert str(err.value) == "test.yaml: boundry: unknown key (did you mean 'boundary'?)"
    with pytest.raises(ConfigError) as err:
        build(moving_obstacles=[{"path": [[0, 0]], "spead": 1.0}])
    assert str(err.value) == ("test.yaml: moving_obstacles[0].spead: unknown key "
                              "(did you mean 'speed'?)")


def test_invalid_values_and_places() -> None:
    with pytest.raises(ConfigError) as err:
        world_from_mapping({"resolution": 0.05}, "w.yaml")
    assert str(err.value) == "w.yaml: size: required key is missing"
    with pytest.raises(ConfigError) as err:
        build(circles=[{"center": [1, 1], "radius": -1}])
    assert str(err.value) == ("test.yaml: circles[0].radius: Input should be greater than 0 "
                              "(got -1)")
    with pytest.raises(ConfigError) as err:
        build(boxes=[{"center": [0.2, 0.2], "size": [0.2, 0.2]}])
    assert str(err.value) == ("test.yaml: spawn: (0.2, 0.2) is inside an obstacle "
                              "(move it to free space)")
    with pytest.raises(ConfigError) as err:
        build(waypoints={"Goal_1": [5.0, 0.5]})
    assert str(err.value) == ("test.yaml: waypoints.Goal_1: (5.0, 0.5) is outside the world "
                              "[0.0, 2.0] x [0.0, 1.0] (move it inside the world)")


# --- moving obstacles -------------------------------------------------------------------
def test_pingpong_positions() -> None:
    ob = MovingObstacle("w", "circle", np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]]), 1.0,
                        "pingpong")
    expected = {0.0: (0.0, 0.0, 0.0), 1.5: (1.5, 0.0, 0.0), 2.5: (2.0, 0.5, math.pi / 2),
                3.0: (2.0, 1.0, math.pi / 2), 3.5: (2.0, 0.5, -math.pi / 2),
                4.5: (1.5, 0.0, math.pi), 5.5: (0.5, 0.0, math.pi), 7.0: (1.0, 0.0, 0.0),
                -1.0: (1.0, 0.0, math.pi)}
    for t, pose in expected.items():
        assert ob.pose_at(t) == pytest.approx(pose, abs=1e-12), t


def test_loop_positions_and_phase() -> None:
    ob = MovingObstacle("w", "circle", np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0],
                                                 [0.0, 1.0]]), 0.5, "loop")
    assert ob.length == 4.0
    expected = {0.0: (0.0, 0.0), 5.0: (0.5, 1.0), 7.0: (0.0, 0.5), 8.0: (0.0, 0.0),
                8.5: (0.25, 0.0), 16.0 + 3.0: (1.0, 0.5)}
    for t, xy in expected.items():
        assert ob.pose_at(t)[:2] == pytest.approx(xy, abs=1e-12), t
    assert ob.pose_at(7.0)[2] == pytest.approx(-math.pi / 2)
    shifted = MovingObstacle("w", "circle", ob.path, 0.5, "loop", phase=1.5)
    assert shifted.pose_at(0.0)[:2] == pytest.approx((1.0, 0.5))


def test_moving_at_circles_and_box_segments() -> None:
    w = build(moving_obstacles=[
        {"name": "a", "shape": "circle", "radius": 0.2, "path": [[0.5, 0.5], [1.5, 0.5]],
         "speed": 0.5},
        {"name": "b", "shape": "box", "size": [0.4, 0.2], "path": [[1.0, 0.2], [1.0, 0.8]],
         "speed": 0.1, "mode": "loop"}])
    circles, segs = w.moving_at(1.0)
    np.testing.assert_allclose(circles, [[1.0, 0.5, 0.2]])
    assert segs.shape == (4, 4)
    # box at (1.0, 0.3) heading +y: 0.4 long along y, 0.2 wide along x
    xs, ys = segs[:, [0, 2]], segs[:, [1, 3]]
    assert xs.min() == pytest.approx(0.9) and xs.max() == pytest.approx(1.1)
    assert ys.min() == pytest.approx(0.1) and ys.max() == pytest.approx(0.5)
    c2, s2 = w.moving_at(1.0)
    np.testing.assert_array_equal(c2, circles)
    np.testing.assert_array_equal(s2, segs)
    assert not w.is_free(1.0, 0.55, t=1.0) and w.is_free(1.0, 0.55)
    assert not w.is_free(1.05, 0.45, t=1.0) and w.is_free(1.05, 0.45, t=0.0)


def test_to_occupancy_grid() -> None:
    w = build(origin=[3.0, -1.0], walls=[{"from": [3.5, -0.5], "to": [4.5, -0.5]}],
              spawn={"x": 3.2, "y": -0.8})
    g = w.to_occupancy_grid()
    assert g.data.dtype == np.int8 and set(np.unique(g.data)) == {0, 100}
    np.testing.assert_array_equal(g.data == 100, w.occupied)
    o = g.info.origin.to_pose2d()
    assert (o.x, o.y, g.info.width, g.info.height) == (3.0, -1.0, 40, 20)


# --- map-file worlds and the catalogue ------------------------------------------------
def test_world_from_map_file_unknown_is_free(tmp_path: Path) -> None:
    data = np.zeros((10, 20), np.int8)
    data[3, :] = 100
    data[7, :5] = -1
    w0 = World(data == 100, 0.1, -1.0, -0.5)
    grid = w0.to_occupancy_grid()
    grid.data[:] = data
    save_map(grid, tmp_path / "m.yaml")
    w = load_world(str(tmp_path / "m.yaml"))
    np.testing.assert_array_equal(w.occupied, data == 100)
    assert (w.origin_x, w.origin_y, w.resolution) == (-1.0, -0.5, 0.1)
    assert w.is_free(-0.95, 0.25)  # an unknown cell
    # no spawn in the file: the free cell farthest from obstacles
    assert w.world_to_cell(w.spawn.x, w.spawn.y)[0] == 9 and w.name == "m"


def test_rotated_map_is_refused(tmp_path: Path) -> None:
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 2\n255\n" + bytes([254] * 4))
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0.3]\n"
                                     "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    with pytest.raises(MapFileError) as err:
        load_world(tmp_path / "m.yaml")
    assert str(err.value) == (f"{tmp_path / 'm.yaml'}: map 'm': origin yaw 0.3 is not "
                              "supported by the simulator; rotate the image instead and set "
                              "yaw 0")


def test_unknown_world_name() -> None:
    with pytest.raises(UnknownNameError) as err:
        load_world("ofice")
    assert str(err.value) == ("unknown world 'ofice' (did you mean 'office'?); known: "
                              "arena, campus, explore_dead_end, explore_facing_wall, "
                              "explore_narrow_door, mars_yard, maze, office, warehouse")
    with pytest.raises(ConfigError) as cerr:
        load_world("no/such/world.yaml")
    assert str(cerr.value) == ("no/such/world.yaml: world file not found (check the path or "
                               "use a built-in world name)")


def test_primitives_file_by_path(tmp_path: Path) -> None:
    p = tmp_path / "room.yaml"
    p.write_text("name: room\nresolution: 0.1\nsize: [3.0, 2.0]\nspawn: {x: 1.0, y: 1.0}\n")
    w = load_world(p)
    assert w.name == "room" and w.occupied.shape == (20, 30) and w.source == p
    assert w.occupied[0].all() and not w.occupied[1:-1, 1:-1].any()


# --- built-in worlds ----------------------------------------------------------------
BUILTIN = ["campus", "mars_yard", "maze", "office", "warehouse"]
MISSION_WORLDS = ["arena", "explore_dead_end", "explore_facing_wall", "explore_narrow_door"]
"""Worlds of the mission issue (tests/sim/test_mission_worlds.py checks them)."""


def test_catalogue() -> None:
    assert list_worlds() == sorted(BUILTIN + MISSION_WORLDS)
    assert world_path("office").name == "office.yaml"
    assert load_world("maze").source == world_path("maze")


@pytest.fixture(scope="module")
def worlds() -> dict[str, World]:
    return {name: load_world(name) for name in BUILTIN}


@pytest.mark.parametrize("name", BUILTIN)
def test_builtin_places_are_clear_and_reachable(worlds: dict[str, World], name: str) -> None:
    w = worlds[name]
    radius = 1.2 if name in ("campus", "mars_yard") else 0.22
    places = {"spawn": w.spawn, **w.waypoints}
    assert len(w.waypoints) >= 3
    # robot-sized dilation of the grid (cells within `radius` of an obstacle cell), then
    # flood fill from the spawn cell
    dist = ndimage.distance_transform_edt(~w.occupied, sampling=w.resolution)
    lab, _ = ndimage.label(dist > radius + w.resolution)
    spawn_label = lab[w.world_to_cell(w.spawn.x, w.spawn.y)]
    assert spawn_label > 0
    for key, p in places.items():
        static = grid_clearance(w.occupied, w.origin_x, w.origin_y, w.resolution, p.x, p.y,
                                10.0)
        assert static >= 0.6, (key, static)
        assert clearance(w, p.x, p.y, 0.0, 10.0) >= 0.5, key
        assert lab[w.world_to_cell(p.x, p.y)] == spawn_label, f"{name}.{key} unreachable"


def test_builtin_worlds_have_moving_obstacles(worlds: dict[str, World]) -> None:
    for name in ("office", "warehouse", "campus"):
        assert len(worlds[name].moving_obstacles) >= 1
    walker = worlds["office"].moving_obstacles[0]
    # the office walker walks the corridor (y 6.6..8.4)
    ys = [walker.pose_at(t)[1] for t in np.linspace(0.0, 60.0, 61)]
    xs = [walker.pose_at(t)[0] for t in np.linspace(0.0, 60.0, 61)]
    assert min(ys) > 6.6 and max(ys) < 8.4 and max(xs) - min(xs) > 10.0


def free_run(line: np.ndarray, index: int) -> int:
    """Length in cells of the run of free cells in ``line`` containing ``index``."""
    assert not line[index]
    lo = index
    while lo > 0 and not line[lo - 1]:
        lo -= 1
    hi = index
    while hi < len(line) - 1 and not line[hi + 1]:
        hi += 1
    return hi - lo + 1


def test_office_doors_and_corridor_widths(worlds: dict[str, World]) -> None:
    w = worlds["office"]
    res = w.resolution
    doors = {6.55: [2.45, 7.45, 12.45, 17.45], 8.45: [3.45, 9.95, 16.45]}
    for y_wall, xs in doors.items():
        for half in (-0.025, 0.025):  # both rows of the 0.1 m wall
            row = w.world_to_cell(0.0, y_wall + half)[0]
            for x in xs:
                gap = free_run(w.occupied[row], w.world_to_cell(x, 0.0)[1]) * res
                assert gap == pytest.approx(0.9), (y_wall, x)
    col = w.world_to_cell(5.5, 0.0)[1]
    corridor = free_run(w.occupied[:, col], w.world_to_cell(0.0, 7.5)[0]) * res
    assert corridor == pytest.approx(1.8)


def test_warehouse_aisles_and_campus_roads(worlds: dict[str, World]) -> None:
    wh = worlds["warehouse"]
    row = wh.world_to_cell(0.0, 14.0)[0]
    for x in (8.25, 15.25, 29.25):
        assert free_run(wh.occupied[row], wh.world_to_cell(x, 0.0)[1]) * wh.resolution == \
            pytest.approx(2.5)
    # campus: an 8 m wide vehicle (radius 4 m) still reaches every waypoint
    cp = worlds["campus"]
    lab, _ = ndimage.label(cp.distance_field() > 4.0 + cp.resolution)
    spawn = lab[cp.world_to_cell(cp.spawn.x, cp.spawn.y)]
    assert spawn > 0
    assert all(lab[cp.world_to_cell(p.x, p.y)] == spawn for p in cp.waypoints.values())


def test_maze_map_file_world(worlds: dict[str, World]) -> None:
    m = worlds["maze"]
    assert (m.origin_x, m.origin_y, m.resolution, m.occupied.shape) == (-5.0, -5.0, 0.05,
                                                                         (200, 200))
    assert m.bounds == (-5.0, -5.0, 5.0, 5.0)
    assert m.occupied[:3].all() and m.occupied[:, -3:].all()
    assert (m.spawn.x, m.spawn.y) == (-4.0, -4.0)

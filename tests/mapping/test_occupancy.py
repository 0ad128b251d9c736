"""Log-odds occupancy grid: exact cell updates, growth, thresholds, files, speed."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from navstack.core.errors import ConfigError, InvalidMessage
from navstack.core.map_files import load_map
from navstack.core.msgs import Header, LaserScan
from navstack.mapping.occupancy import (
    HIT_DEPTH,
    L_FREE_DEFAULT,
    L_OCC_DEFAULT,
    LogOddsGrid,
    LogOddsParams,
    MapGrowthError,
    MappingError,
    ScanData,
    free_thresh_after,
    logit,
    scan_endpoints,
)

RES = 0.05


def room_scan(sensor: tuple[float, float], beams: int = 3600, half: float = 2.0,
              depth: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """End points ``depth`` behind the inner surface of the square room |x|, |y| < half."""
    ang = np.linspace(-math.pi, math.pi, beams, endpoint=False)
    c, s = np.cos(ang), np.sin(ang)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (half - sensor[0]) / c, (-half - sensor[0]) / c)
        ty = np.where(s > 0, (half - sensor[1]) / s, (-half - sensor[1]) / s)
    r = np.minimum(np.abs(tx), np.abs(ty)) + depth
    return np.stack((sensor[0] + r * c, sensor[1] + r * s), axis=1), np.ones(beams, bool)


def observed_block(g: LogOddsGrid) -> tuple[tuple[float, float], np.ndarray]:
    """World origin and log-odds of the bounding box of the observed cells."""
    rows, cols = np.nonzero(g.observed)
    r0, c0 = rows.min(), cols.min()
    block = g.log_odds[r0:rows.max() + 1, c0:cols.max() + 1]
    return (g.origin[0] + c0 * RES, g.origin[1] + r0 * RES), block


def test_defaults_are_the_documented_log_odds() -> None:
    p = LogOddsParams()
    assert p.l_occ == pytest.approx(math.log(0.7 / 0.3))
    assert p.l_free == pytest.approx(math.log(0.4 / 0.6))
    assert (p.l_min, p.l_max, p.resolution) == (-5.0, 5.0, 0.05)
    assert logit(0.7) == L_OCC_DEFAULT
    assert logit(0.4) == L_FREE_DEFAULT


def test_single_beam_along_x_marks_cells_between_free_and_end_cell_occupied() -> None:
    g = LogOddsGrid(RES)
    g.integrate_scan([0.025, 0.025], [[1.025, 0.025]], [True])
    r, c = g.world_to_cell(0.025, 0.025)
    assert (r, c) == g.world_to_cell(0.0, 0.0)
    lo = g.log_odds
    np.testing.assert_array_equal(lo[r, c:c + 20], np.float32(L_FREE_DEFAULT))
    assert lo[r, c + 20] == np.float32(L_OCC_DEFAULT)
    assert g.observed.sum() == 21 and np.count_nonzero(lo) == 21
    assert g.observed[r, c:c + 21].all()
    # the grid grew around the beam with the 2 m margin, on the lattice of world (0, 0)
    assert g.origin == (-2.0, -2.0)
    assert g.cell_center(r, c + 20) == pytest.approx((1.025, 0.025))


def test_square_room_gives_occupied_cells_exactly_on_the_walls_and_free_inside() -> None:
    g = LogOddsGrid(RES, bounds=(-3.0, -3.0, 3.0, 3.0))
    ends, hits = room_scan((0.01, 0.02))
    for _ in range(4):  # four scans bring free cells below free_thresh (4 * logit(0.4))
        g.integrate_scan([0.01, 0.02], ends, hits)
    data = g.to_occupancy_grid().data
    assert data.shape == (120, 120) and g.origin == (-3.0, -3.0)
    # cells [2.0, 2.05) are column/row 100, [-2.05, -2.0) are 19
    expected = np.full((120, 120), -1, np.int8)
    expected[19:101, 19:101] = 100
    expected[20:100, 20:100] = 0
    corners = [(19, 19), (19, 100), (100, 19), (100, 100)]
    for rc in corners:
        assert data[rc] in (100, -1)  # a beam reaches a corner cell only past the corner
        expected[rc] = data[rc]
    np.testing.assert_array_equal(data, expected)
    wall = expected == 100
    np.testing.assert_allclose(g.log_odds[wall], 4 * L_OCC_DEFAULT, rtol=1e-6)
    np.testing.assert_allclose(g.log_odds[expected == 0], 4 * L_FREE_DEFAULT, rtol=1e-6)


def test_each_cell_is_updated_once_per_scan_and_hits_win() -> None:
    g = LogOddsGrid(RES, bounds=(0.0, 0.0, 2.0, 2.0))
    # two beams end in cell (10, 30); a third crosses it on its way to (10, 35)
    g.integrate_scan([0.525, 0.525], [[1.51, 0.52], [1.54, 0.53], [1.775, 0.525]],
                     [True, True, True])
    assert g.log_odds[10, 30] == np.float32(L_OCC_DEFAULT)
    assert g.log_odds[10, 35] == np.float32(L_OCC_DEFAULT)
    assert g.log_odds[10, 20] == np.float32(L_FREE_DEFAULT)
    g.integrate_scan([0.525, 0.525], [[1.775, 0.525]], [True])  # next scan clears it
    assert g.log_odds[10, 30] == pytest.approx(L_OCC_DEFAULT + L_FREE_DEFAULT, rel=1e-6)
    assert g.scan_count == 2
    for _ in range(15):
        g.integrate_scan([0.525, 0.525], [[1.775, 0.525]], [True])
    assert g.log_odds[10, 35] == 5.0 and g.log_odds[10, 20] == -5.0  # clamped


def test_growth_keeps_old_cells_at_the_same_world_coordinates() -> None:
    g = LogOddsGrid(RES, bounds=(0.0, 0.0, 2.0, 2.0), grow_margin=1.0)
    g.integrate_scan([0.513, 0.512], [[1.512, 0.514], [1.912, 0.263]], [True, True])
    old_l, old_obs = g.log_odds.copy(), g.observed.copy()
    old_origin, (h, w) = g.origin, g.shape
    # leaves the grid to the lower left; passes nowhere near the cells observed so far
    g.integrate_scan([1.013, 1.512], [[-4.013, -3.012]], [True])
    (ox, oy), (nh, nw) = g.origin, g.shape
    dc, dr = round((old_origin[0] - ox) / RES), round((old_origin[1] - oy) / RES)
    assert (ox, oy) == pytest.approx((old_origin[0] - dc * RES, old_origin[1] - dr * RES))
    assert dc >= 4.013 / RES and dr >= 3.012 / RES
    assert nw >= w + w // 2 and nh >= h + h // 2  # amortised: at least half again
    block_l = g.log_odds[dr:dr + h, dc:dc + w]
    np.testing.assert_array_equal(block_l[old_obs], old_l[old_obs])
    for r, c in zip(*np.nonzero(old_obs), strict=True):
        x, y = old_origin[0] + (c + 0.5) * RES, old_origin[1] + (r + 0.5) * RES
        assert g.log_odds[g.world_to_cell(x, y)] == old_l[r, c]
    assert g.log_odds[g.world_to_cell(-4.013, -3.012)] == np.float32(L_OCC_DEFAULT)
    # and to the upper right, from a sensor outside the grid: every old cell is kept
    before, before_obs = g.log_odds.copy(), g.observed.copy()
    g.integrate_scan([5.013, 4.512], [[6.013, 5.012]], [True])
    assert g.origin == (ox, oy) and g.shape[0] > nh and g.shape[1] > nw
    np.testing.assert_array_equal(g.log_odds[:nh, :nw], before)
    np.testing.assert_array_equal(g.observed[:nh, :nw], before_obs)
    assert g.log_odds[g.world_to_cell(6.013, 5.012)] == np.float32(L_OCC_DEFAULT)


def test_fixed_grid_stops_rays_at_the_border() -> None:
    g = LogOddsGrid(RES, bounds=(0.0, 0.0, 1.0, 1.0), growable=False)
    g.integrate_scan([0.525, 0.525], [[3.025, 0.525]], [True])  # leaves through x = 1
    assert g.shape == (20, 20)
    np.testing.assert_array_equal(g.log_odds[10, 10:], np.float32(L_FREE_DEFAULT))
    assert g.observed.sum() == 10 and (g.log_odds <= 0).all()
    g.integrate_scan([-1.0, 0.275], [[3.0, 0.275], [-1.0, 5.0]], [True, True])
    np.testing.assert_array_equal(g.observed[5], np.ones(20, bool))  # crossed the grid
    assert g.observed.sum() == 30
    g.integrate_scan([-1.0, -1.0], [[-2.0, 7.0]], [True])  # never enters
    assert g.observed.sum() == 30 and (g.log_odds <= 0).all()


def test_thresholds_are_respected() -> None:
    g = LogOddsGrid(RES, bounds=(0.0, 0.0, 1.0, 1.0))
    g.integrate_scan([0.125, 0.125], [[0.275, 0.125]], [True])  # 3 free, 1 hit: p 0.4, 0.7
    row = g.to_occupancy_grid().data[2]
    np.testing.assert_array_equal(row[:7], [-1, -1, -1, -1, -1, 100, -1])
    assert g.to_occupancy_grid(occupied_thresh=0.75).data[2, 5] == -1
    np.testing.assert_array_equal(g.to_occupancy_grid(free_thresh=0.45).data[2, :7],
                                  [-1, -1, 0, 0, 0, 100, -1])
    prob = g.to_occupancy_grid(mode="probability").data[2]
    np.testing.assert_array_equal(prob[:7], [-1, -1, 40, 40, 40, 70, -1])
    np.testing.assert_allclose(g.probability()[2, :7], [0.5, 0.5, 0.4, 0.4, 0.4, 0.7, 0.5],
                               rtol=1e-6)
    with pytest.raises(MappingError, match="must satisfy 0 <= free_thresh < occupied_thresh"):
        g.to_occupancy_grid(occupied_thresh=0.2, free_thresh=0.3)


def test_free_thresh_after_shows_a_cell_free_after_exactly_that_many_crossing_scans() -> None:
    # map_server's free_thresh 0.196 lies between 3 and 4 OctoMap misses
    assert free_thresh_after(4) == pytest.approx(0.1948, abs=1e-4)
    assert free_thresh_after(4) < 0.196 < free_thresh_after(3)
    g = LogOddsGrid(RES, bounds=(0.0, 0.0, 1.0, 1.0))
    row = []
    for _ in range(5):  # the same beam again: cells 2-4 crossed, cell 5 hit each time
        g.integrate_scan([0.125, 0.125], [[0.275, 0.125]], [True])
        row.append([g.to_occupancy_grid(free_thresh=free_thresh_after(n)).data[2, 3]
                    for n in (1, 2, 3, 4)])
    assert row == [[0, -1, -1, -1], [0, 0, -1, -1], [0, 0, 0, -1], [0, 0, 0, 0],
                   [0, 0, 0, 0]]
    # a cell some scan ended in needs more: one hit and two misses is not free after 2
    h = LogOddsGrid(RES, bounds=(0.0, 0.0, 1.0, 1.0))
    h.integrate_scan([0.125, 0.125], [[0.275, 0.125]], [True])
    h.integrate_scan([0.125, 0.125], [[0.475, 0.125]], [True])
    h.integrate_scan([0.125, 0.125], [[0.475, 0.125]], [True])
    data = h.to_occupancy_grid(free_thresh=free_thresh_after(2)).data[2]
    assert data[5] == -1 and data[4] == 0 and data[9] == 100
    with pytest.raises(MappingError, match="scans must be at least 1"):
        free_thresh_after(0)
    with pytest.raises(MappingError, match="l_free must be negative"):
        free_thresh_after(2, l_free=0.1)


def test_scan_endpoints_range_semantics() -> None:
    pose = (1.0, 2.0, math.pi / 2)
    ranges = [3.0, np.inf, 12.0, 8.0, np.nan, -np.inf, 0.05, 10.0]
    angles = [0.0, 0.1, 0.2, -math.pi / 2, 0.4, 0.5, 0.6, 0.7]
    ends, hits = scan_endpoints(pose, ranges, angles, 0.1, 10.0, max_usable_range=5.0)
    # kept: the return, two no-returns (inf, >= range_max, also == range_max), the long
    # return clipped to 5 m; dropped: NaN, -inf, below range_min
    np.testing.assert_array_equal(hits, [True, False, False, False, False])
    dist = np.hypot(ends[:, 0] - 1.0, ends[:, 1] - 2.0)
    # a return is marked HIT_DEPTH (1 mm) inside the surface it hit
    np.testing.assert_allclose(dist, [3.0 + HIT_DEPTH, 5.0, 5.0, 5.0, 5.0])
    np.testing.assert_allclose(ends[0], [1.0, 5.0 + HIT_DEPTH], atol=1e-12)
    np.testing.assert_allclose(ends[3], [6.0, 2.0], atol=1e-12)
    ends2, hits2 = scan_endpoints(pose, ranges, angles, 0.1, 10.0, 5.0, clear_no_returns=False)
    np.testing.assert_array_equal(hits2, [True, False])
    np.testing.assert_allclose(ends2, ends[[0, 3]])


def test_no_return_beam_marks_no_occupied_cell() -> None:
    g = LogOddsGrid(RES)
    ends, hits = scan_endpoints((0.0, 0.0, 0.0), [np.inf, 30.0], [0.0, math.pi / 2], 0.1,
                                30.0, 4.0)
    assert not hits.any()
    g.integrate_scan([0.0, 0.0], ends, hits)
    assert (g.log_odds <= 0).all()
    r, c = g.world_to_cell(0.0, 0.0)
    assert g.observed[r, c:c + 81].all() and g.observed[r:r + 81, c].all()
    assert g.observed.sum() == 161
    assert (g.to_occupancy_grid(free_thresh=0.45).data != 100).all()


def test_integrate_scans_equals_scan_by_scan_and_accepts_laser_scans() -> None:
    ranges = np.array([1.0, 2.0, np.inf, 1.5], np.float32)
    msg = LaserScan(Header(0.0, "laser"), -0.3, 0.3, 0.2, 0.0, 0.1, 0.05, 3.0, ranges)
    angles = -0.3 + 0.2 * np.arange(4)
    base = np.array([[0.0, 0.0, 0.0], [0.5, 0.2, 0.3], [1.0, -0.4, -1.2]])
    mount = (0.1, 0.05, 0.2)
    bulk = LogOddsGrid(RES)
    bulk.integrate_scans(base, [msg, ScanData(ranges, angles, 0.05, 3.0), msg],
                         max_usable_range=2.5, sensor_pose=mount)
    single = LogOddsGrid(RES)
    from navstack.core.geometry import se2_compose

    for pose in se2_compose(base, np.array(mount)):
        ends, hits = scan_endpoints(pose, ranges, angles, 0.05, 3.0, 2.5)
        single.integrate_scan(pose[:2], ends, hits)
    assert bulk.scan_count == 3
    (o_bulk, l_bulk), (o_single, l_single) = observed_block(bulk), observed_block(single)
    assert o_bulk == pytest.approx(o_single, abs=1e-12)
    np.testing.assert_array_equal(l_bulk, l_single)
    assert (l_bulk > 0).sum() == 9  # 3 returns within 2.5 m per scan, all in distinct cells
    with pytest.raises(MappingError, match="2 poses for 3 scans"):
        bulk.integrate_scans(base[:2], [msg, msg, msg])


def test_save_then_load_map_returns_identical_cells(tmp_path: Path) -> None:
    g = LogOddsGrid(RES)
    ends, hits = room_scan((0.31, -0.22), beams=720, half=1.0)
    for _ in range(4):
        g.integrate_scan([0.31, -0.22], ends, hits)
    grid = g.to_occupancy_grid(crop=True)
    image = g.save(tmp_path / "room.yaml")
    assert image.name == "room.pgm"
    loaded = load_map(tmp_path / "room.yaml")
    np.testing.assert_array_equal(loaded.data, grid.data)
    assert loaded.info.resolution == RES
    assert loaded.info.origin.position.x == grid.info.origin.position.x
    assert loaded.info.origin.position.y == grid.info.origin.position.y
    assert grid.info.origin.position.x == pytest.approx(-1.05, abs=1e-12)
    assert grid.info.origin.position.y == pytest.approx(-1.05, abs=1e-12)
    assert grid.data.shape == (42, 42)  # cropped to the observed walls
    assert loaded.data[loaded.world_to_cell(1.02, 0.0)] == 100
    assert loaded.data[loaded.world_to_cell(0.5, 0.5)] == 0
    # one scan, classified with a free_thresh above 0.196: the YAML keeps 0.196, so the
    # cells left unknown stay unknown on reload
    one = LogOddsGrid(RES)
    one.integrate_scan([0.31, -0.22], ends, hits)
    lenient = one.to_occupancy_grid(crop=True, free_thresh=free_thresh_after(1))
    one.save(tmp_path / "lenient.yaml", free_thresh=free_thresh_after(1))
    assert "free_thresh: 0.196" in (tmp_path / "lenient.yaml").read_text()
    again = load_map(tmp_path / "lenient.yaml")
    np.testing.assert_array_equal(again.data, lenient.data)
    assert np.count_nonzero(again.data == 0) == np.count_nonzero(loaded.data == 0)
    assert np.count_nonzero(one.to_occupancy_grid(crop=True).data == 0) == 0


def test_save_png_is_north_up_greyscale(tmp_path: Path) -> None:
    g = LogOddsGrid(RES, bounds=(0.0, 0.0, 1.0, 1.0))
    g.integrate_scan([0.125, 0.125], [[0.125, 0.475]], [True])  # up along column 2
    path = g.save_png(tmp_path / "map.png")
    img = np.asarray(Image.open(path))
    grey = np.rint(255.0 * (1.0 - g.probability()))
    assert img.shape == (8, 1)  # cropped to rows 2..9 of column 2, top row = row 9
    assert img[0, 0] == grey[9, 2] and grey[9, 2] in (76, 77)
    np.testing.assert_array_equal(img[1:, 0], np.full(7, 153))
    full = np.asarray(Image.open(g.save_png(tmp_path / "full.png", crop=False)))
    assert full.shape == (20, 20) and full[0, 0] == 205 and full[19 - 9, 2] == grey[9, 2]


def test_bad_input_is_refused_with_clear_errors() -> None:
    g = LogOddsGrid(RES, max_cells=10_000)
    with pytest.raises(InvalidMessage, match="NaN or inf"):
        g.integrate_scan([0.0, 0.0], [[np.nan, 1.0]], [True])
    with pytest.raises(MappingError, match=r"shape \(N, 2\) and hit_mask \(N,\)"):
        g.integrate_scan([0.0, 0.0], [[1.0, 1.0]], [True, False])
    with pytest.raises(MapGrowthError, match="max_cells 10000"):
        g.integrate_scan([0.0, 0.0], [[1000.0, 0.0]], [True])
    with pytest.raises(MappingError, match="nothing has been observed"):
        g.to_occupancy_grid(crop=True)
    with pytest.raises(ConfigError, match="l_occ"):
        LogOddsGrid(RES, l_occ=-1.0)
    with pytest.raises(MappingError, match="x_max > x_min"):
        LogOddsGrid(RES, bounds=(1.0, 0.0, 0.0, 1.0))


def test_360_beam_scans_from_moving_origins_mark_ends_occupied_and_rays_free() -> None:
    """200 full-circle scans from origins a few cm apart: the last scan's end cells are
    occupied (beams of the other origins graze a tenth of them) and the space between is
    free (the timing budget is ``navstack bench slam``'s)."""
    g = LogOddsGrid(RES, bounds=(-10.0, -10.0, 10.0, 10.0))
    ang = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    ends = np.stack((9.9 * np.cos(ang), 9.9 * np.sin(ang)), axis=1)
    hits = np.ones(360, bool)
    g.integrate_scan([0.0, 0.0], ends, hits)  # compile / load the cache
    for i in range(200):
        o = np.array([0.013 * (i % 7), -0.011 * (i % 5)])
        g.integrate_scan(o, ends + o, hits)
    assert g.shape == (400, 400)
    p = g.probability()
    assert np.mean([p[g.world_to_cell(*end)] > 0.5 for end in ends + o]) > 0.85
    assert all(p[g.world_to_cell(*(0.5 * end))] < 0.5 for end in ends[::10])


def _room_ranges(sensor: tuple[float, float], ang: np.ndarray, rng: np.random.Generator,
                 person: tuple[float, float, float] | None = None) -> np.ndarray:
    """Ranges from ``sensor`` inside the room -3 < x < 3, -1 < y < 1 (walls' faces on cell
    boundaries), 1 cm noise, optionally blocked by a round ``person`` (x, y, radius)."""
    c, s = np.cos(ang), np.sin(ang)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (3.0 - sensor[0]) / c, (-3.0 - sensor[0]) / c)
        ty = np.where(s > 0, (1.0 - sensor[1]) / s, (-1.0 - sensor[1]) / s)
    r = np.minimum(np.abs(tx), np.abs(ty))
    if person is not None:
        px, py, pr = person[0] - sensor[0], person[1] - sensor[1], person[2]
        b = c * px + s * py
        disc = b * b - (px * px + py * py - pr * pr)
        t = b - np.sqrt(np.maximum(disc, 0.0))
        r = np.where((disc > 0) & (t > 0), np.minimum(r, t), r)
    return r + rng.normal(0.0, 0.01, r.size)


def test_clear_only_scans_erase_a_person_but_keep_a_wall_face_on_a_cell_boundary() -> None:
    """The live SLAM map: node scans mark, the latest scans only clear.  A wall whose face
    lies on a cell boundary (y = 1.0) is hit in both cells around it; scans that graze it
    cross those cells, yet the wall must stay occupied (it was eroded to unknown and
    exploration saw frontiers along it), while a person the node scans saw and the latest
    scans see through is erased."""
    rng = np.random.default_rng(3)
    ang = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    g = LogOddsGrid(RES)
    person = (1.5, 0.0, 0.2)
    for k in range(6):  # node scans, the person standing there
        sensor = (-1.0 + 0.4 * k, 0.75)
        g.integrate_scans([[*sensor, 0.0]], [ScanData(_room_ranges(sensor, ang, rng, person),
                                                      ang, 0.05, 10.0)])
    before = g.to_occupancy_grid().data
    face = g.world_to_cell(0.5, 0.99)
    assert before[g.world_to_cell(0.5, 1.01)] == 100
    assert before[g.world_to_cell(1.3, 0.0)] == 100  # the person's near side
    live = g.copy()
    for k in range(20):  # the latest scans: the person walked away
        sensor = (0.5 + 0.02 * k, 0.75)
        live.integrate_scans([[*sensor, 0.0]], [ScanData(_room_ranges(sensor, ang, rng), ang,
                                                         0.05, 10.0)], clear_only=True)
    after = live.to_occupancy_grid().data
    assert after[g.world_to_cell(1.3, 0.0)] == 0  # erased
    # the wall along the whole stretch the latest scans see keeps every occupied cell
    for x in np.arange(-2.0, 2.0, RES):
        for y in (0.99, 1.01):
            cell = g.world_to_cell(float(x), y)
            if before[cell] == 100:
                assert after[cell] == 100, (x, y)
    assert before[face] == 100 or before[g.world_to_cell(0.5, 1.01)] == 100


@pytest.mark.parametrize(("occupied", "free"), [(0.65, 0.196), (0.6, 0.3), (1.0, 0.0)])
def test_trinary_grid_compares_log_odds_exactly_as_probabilities(occupied: float,
                                                                  free: float) -> None:
    from navstack.mapping.occupancy import _probability, _trinary_bounds

    g = LogOddsGrid(0.05, bounds=(0.0, 0.0, 10.0, 10.0))
    rng = np.random.default_rng(2)
    shape = g._l.shape
    lv = (rng.standard_normal(shape) * 2.0).astype(np.float32)
    bounds = _trinary_bounds(occupied, free)
    assert (bounds is None) == (occupied == 1.0)
    if bounds is not None:  # plant values at and next to each bound
        for k, b in enumerate(bounds):
            near = [np.nextafter(b, np.float32(-9)), b, np.nextafter(b, np.float32(9))]
            lv.ravel()[150 * k:150 * (k + 1)] = np.tile(np.array(near, np.float32), 50)
    g._l[:] = lv
    g._mark[:] = (rng.random(shape) < 0.9).astype(np.int32)
    grid = g.to_occupancy_grid(occupied_thresh=occupied, free_thresh=free)
    p = _probability(lv)
    expected = np.full(shape, -1, np.int8)
    obs = g._mark > 0
    expected[obs & (p > occupied)] = 100
    expected[obs & (p < free)] = 0
    np.testing.assert_array_equal(grid.data, expected)
    assert (grid.data == -1).any() and (grid.data == 0).any() == (free > 0.0)
    assert (grid.data == 100).any() == (occupied < 1.0)

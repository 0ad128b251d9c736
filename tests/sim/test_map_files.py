"""ROS map_server map files: value interpretation, flip, origin, round trip, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from navstack.core.errors import MapFileError
from navstack.core.map_files import load_map, save_map
from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose, Quaternion

DATA = Path(__file__).resolve().parents[1] / "data"


def write_pgm(path: Path, pixels: np.ndarray, maxval: int = 255) -> None:
    """P5 PGM with image row 0 at the top."""
    h, w = pixels.shape
    dtype = np.uint8 if maxval < 256 else np.dtype(">u2")
    path.write_bytes(f"P5\n# test\n{w} {h}\n{maxval}\n".encode()
                     + np.ascontiguousarray(pixels, dtype=dtype).tobytes())


def write_yaml(path: Path, image: str = "m.pgm", **overrides: object) -> Path:
    fields: dict[str, object] = {"image": image, "resolution": 0.05,
                                 "origin": "[1.5, -2.0, 0.0]", "negate": 0,
                                 "occupied_thresh": 0.65, "free_thresh": 0.196}
    fields.update(overrides)
    path.write_text("".join(f"{k}: {v}\n" for k, v in fields.items() if v is not None))
    return path


def load_pixels(tmp_path: Path, pixels: list[list[int]], **yaml_fields: object) -> np.ndarray:
    write_pgm(tmp_path / "m.pgm", np.array(pixels))
    return load_map(write_yaml(tmp_path / "m.yaml", **yaml_fields)).data


def test_trinary_thresholds_and_flip(tmp_path: Path) -> None:
    # p = (255 - v) / 255: 89 -> 0.651 > 0.65 occupied, 90 -> 0.647 unknown,
    # 205 -> 0.19608 (not < 0.196) unknown, 206 -> 0.192 free.
    data = load_pixels(tmp_path, [[0, 89, 90, 205],
                                  [206, 254, 255, 128]])
    assert data.dtype == np.int8 and data.shape == (2, 4)
    # image row 0 is the top of the map -> grid row 1
    np.testing.assert_array_equal(data, [[0, 0, 0, -1],
                                         [100, 100, -1, -1]])


def test_origin_resolution_and_world_to_cell(tmp_path: Path) -> None:
    write_pgm(tmp_path / "m.pgm", np.full((3, 5), 254))
    grid = load_map(write_yaml(tmp_path / "m.yaml", resolution=0.25,
                               origin="[1.5, -2.0, 0.0]"))
    assert (grid.info.width, grid.info.height) == (5, 3)
    assert grid.info.resolution == 0.25
    o = grid.info.origin.to_pose2d()
    assert (o.x, o.y, o.theta) == (1.5, -2.0, 0.0)
    assert grid.header.frame_id == "map"
    # the outer corner of cell (0, 0) is the origin
    assert grid.world_to_cell(1.5 + 0.01, -2.0 + 0.01) == (0, 0)
    assert grid.world_to_cell(1.5 + 4 * 0.25 + 0.1, -2.0 + 2 * 0.25 + 0.1) == (2, 4)


def test_origin_yaw_is_read(tmp_path: Path) -> None:
    write_pgm(tmp_path / "m.pgm", np.full((2, 2), 254))
    grid = load_map(write_yaml(tmp_path / "m.yaml", origin="[0.0, 0.0, 0.5]"))
    assert grid.info.origin.orientation.yaw == pytest.approx(0.5, abs=1e-12)


def test_negate_swaps_black_and_white(tmp_path: Path) -> None:
    data = load_pixels(tmp_path, [[0, 255, 166, 50]], negate=1)
    # p = v / 255: 0 free, 255 occupied, 166 -> 0.651 occupied, 50 -> 0.196 unknown
    np.testing.assert_array_equal(data, [[0, 100, 100, -1]])


def test_raw_mode_keeps_values(tmp_path: Path) -> None:
    data = load_pixels(tmp_path, [[0, 37, 100, 101, 255]], mode="raw")
    np.testing.assert_array_equal(data, [[0, 37, 100, -1, -1]])


def test_scale_mode_linear_band_and_alpha(tmp_path: Path) -> None:
    free, occ = 0.2, 0.7
    grey = np.array([[255, 0, 153, 140, 153, 0]], dtype=np.uint8)
    alpha = np.array([[255, 255, 255, 255, 0, 0]], dtype=np.uint8)
    Image.fromarray(np.dstack((grey, alpha))).save(tmp_path / "m.png")
    grid = load_map(write_yaml(tmp_path / "m.yaml", image="m.png", mode="scale",
                               free_thresh=free, occupied_thresh=occ))
    p153, p140 = (255 - 153) / 255, (255 - 140) / 255
    expect = [0, 100, round(100 * (p153 - free) / (occ - free)),
              round(100 * (p140 - free) / (occ - free)),
              -1,     # transparent in the middle band: unknown
              100]    # transparent but beyond occupied_thresh: still occupied
    np.testing.assert_array_equal(grid.data, [expect])
    assert expect[2:4] == [40, 50]


def test_ascii_pgm_with_comments_fixture() -> None:
    grid = load_map(DATA / "tiny_p2.yaml")
    np.testing.assert_array_equal(grid.data, [[0, 0, 100, 100],
                                              [100, -1, 0, -1],
                                              [100, 0, -1, 0]])
    o = grid.info.origin.to_pose2d()
    assert (o.x, o.y, grid.info.resolution) == (-1.0, 2.0, 0.5)


def test_16bit_pgm_is_scaled(tmp_path: Path) -> None:
    write_pgm(tmp_path / "m.pgm", np.array([[0, 65535, 52685]]), maxval=65535)
    data = load_map(write_yaml(tmp_path / "m.yaml")).data
    np.testing.assert_array_equal(data, [[100, 0, -1]])  # 52685/257 = 205


def test_colour_png_channels_are_averaged(tmp_path: Path) -> None:
    rgb = np.array([[[255, 255, 255], [0, 0, 0], [255, 0, 0], [255, 255, 105]]], np.uint8)
    Image.fromarray(rgb).save(tmp_path / "m.png")
    data = load_map(write_yaml(tmp_path / "m.yaml", image="m.png")).data
    # averages 255, 0, 85 (p=0.667 occupied), 205 (unknown)
    np.testing.assert_array_equal(data, [[0, 100, 100, -1]])


def make_grid(data: np.ndarray, res: float = 0.05, origin: tuple[float, float] = (-3.25, 7.5)
              ) -> OccupancyGrid:
    info = MapMetaData(resolution=res, width=data.shape[1], height=data.shape[0],
                       origin=Pose(Point(origin[0], origin[1], 0.0), Quaternion()))
    return OccupancyGrid(Header(0.0, "map"), info, data.astype(np.int8))


def test_trinary_save_load_round_trip_is_exact(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    data = rng.choice(np.array([-1, 0, 100], dtype=np.int8), size=(37, 53))
    grid = make_grid(data, res=0.05, origin=(-3.25, 7.5))
    img = save_map(grid, tmp_path / "out" / "saved.yaml")
    assert img == tmp_path / "out" / "saved.pgm"
    text = (tmp_path / "out" / "saved.yaml").read_text()
    assert "image: saved.pgm\n" in text and "mode: trinary\n" in text
    assert "occupied_thresh: 0.65\n" in text and "free_thresh: 0.196\n" in text
    raw = img.read_bytes()
    assert raw.startswith(b"P5\n")
    pixels = np.frombuffer(raw[-data.size:], np.uint8).reshape(data.shape)
    assert set(np.unique(pixels)) == {0, 205, 254}
    assert pixels[0, 0] == {-1: 205, 0: 254, 100: 0}[int(data[-1, 0])]  # top row = last row
    back = load_map(tmp_path / "out" / "saved.yaml")
    np.testing.assert_array_equal(back.data, data)
    assert back.info.resolution == 0.05
    o = back.info.origin.to_pose2d()
    assert (o.x, o.y) == (-3.25, 7.5)


def test_trinary_save_uses_thresholds_for_intermediate_values(tmp_path: Path) -> None:
    grid = make_grid(np.array([[0, 19, 20, 21, 64, 65, 100, -1]]))
    save_map(grid, tmp_path / "s.yaml")
    back = load_map(tmp_path / "s.yaml").data
    np.testing.assert_array_equal(back, [[0, 0, 0, -1, -1, 100, 100, -1]])


def test_raw_save_load_round_trip_is_exact(tmp_path: Path) -> None:
    data = np.arange(-1, 101, dtype=np.int8).reshape(6, 17)
    save_map(make_grid(data), tmp_path / "r.yaml", mode="raw")
    np.testing.assert_array_equal(load_map(tmp_path / "r.yaml").data, data)


def test_scale_save_keeps_unknown_and_extremes(tmp_path: Path) -> None:
    data = np.array([[-1, 0, 100, 10, 90]], dtype=np.int8)
    img = save_map(make_grid(data), tmp_path / "sc.yaml", mode="scale")
    assert img.suffix == ".png"
    back = load_map(tmp_path / "sc.yaml").data
    # 10 -> grey 230 -> p 0.098 free; 90 -> grey 25 -> p 0.902 occupied
    np.testing.assert_array_equal(back, [[-1, 0, 100, 0, 100]])


# --- errors ---------------------------------------------------------------------------
def test_missing_yaml(tmp_path: Path) -> None:
    path = tmp_path / "nope.yaml"
    with pytest.raises(MapFileError) as err:
        load_map(path)
    assert str(err.value).startswith(f"{path}: map YAML file not found; check the path")


def test_missing_image_names_the_path_looked_for(tmp_path: Path) -> None:
    yaml_path = write_yaml(tmp_path / "m.yaml", image="maps/missing.pgm")
    with pytest.raises(MapFileError) as err:
        load_map(yaml_path)
    assert str(err.value) == (
        f"{yaml_path}: image file '{tmp_path / 'maps' / 'missing.pgm'}' not found; the "
        "'image' key is resolved relative to the YAML's folder")


def test_corrupt_png(tmp_path: Path) -> None:
    (tmp_path / "m.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage garbage")
    with pytest.raises(MapFileError) as err:
        load_map(write_yaml(tmp_path / "m.yaml", image="m.png"))
    msg = str(err.value)
    assert msg.startswith(f"{tmp_path / 'm.png'}: cannot read map image (")
    assert msg.endswith("re-save it as an 8-bit grayscale PGM or PNG")
    assert "\n" not in msg


def test_truncated_pgm(tmp_path: Path) -> None:
    (tmp_path / "m.pgm").write_bytes(b"P5\n10 10\n255\n" + bytes(50))
    with pytest.raises(MapFileError) as err:
        load_map(write_yaml(tmp_path / "m.yaml"))
    assert str(err.value) == (f"{tmp_path / 'm.pgm'}: truncated PGM data (50 bytes for a "
                              "10x10 image); the file is damaged, re-save the map")


def test_missing_key(tmp_path: Path) -> None:
    yaml_path = write_yaml(tmp_path / "m.yaml", resolution=None)
    with pytest.raises(MapFileError) as err:
        load_map(yaml_path)
    assert str(err.value) == (f"{yaml_path}: required key 'resolution' is missing; a "
                              "map_server YAML needs image, resolution, origin, "
                              "occupied_thresh, free_thresh")


@pytest.mark.parametrize(("free", "occ"), [(0.7, 0.65), (0.65, 0.65), (-0.1, 0.5), (0.2, 1.5)])
def test_bad_thresholds(tmp_path: Path, free: float, occ: float) -> None:
    yaml_path = write_yaml(tmp_path / "m.yaml", free_thresh=free, occupied_thresh=occ)
    with pytest.raises(MapFileError) as err:
        load_map(yaml_path)
    assert str(err.value) == (
        f"{yaml_path}: free_thresh {free} and occupied_thresh {occ} must satisfy "
        "0 <= free_thresh < occupied_thresh <= 1; typical values are free_thresh: 0.196, "
        "occupied_thresh: 0.65")


@pytest.mark.parametrize("res", [0, -0.05])
def test_non_positive_resolution(tmp_path: Path, res: float) -> None:
    yaml_path = write_yaml(tmp_path / "m.yaml", resolution=res)
    with pytest.raises(MapFileError) as err:
        load_map(yaml_path)
    assert str(err.value) == (f"{yaml_path}: resolution must be positive (got {res}); set it "
                              "to the map's metres per pixel, e.g. 0.05")


def test_invalid_yaml_syntax_and_bad_mode(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: m.pgm\nresolution: [0.05\n")
    with pytest.raises(MapFileError) as err:
        load_map(bad)
    assert str(err.value).startswith(f"{bad}: invalid YAML at line ")
    yaml_path = write_yaml(tmp_path / "m.yaml", mode="fancy")
    with pytest.raises(MapFileError) as err:
        load_map(yaml_path)
    assert str(err.value) == f"{yaml_path}: unknown mode 'fancy'; use one of trinary, scale, raw"


def test_bad_origin(tmp_path: Path) -> None:
    yaml_path = write_yaml(tmp_path / "m.yaml", origin="[1.0, 2.0]")
    with pytest.raises(MapFileError) as err:
        load_map(yaml_path)
    assert str(err.value) == (f"{yaml_path}: origin must be [x, y, yaw] numbers, got "
                              "[1.0, 2.0]; e.g. origin: [0.0, 0.0, 0.0]")

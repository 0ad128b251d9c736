"""ROS map_server map files: a YAML of metadata plus an occupancy image.

``load_map`` follows ROS map_server / Nav2 ``nav2_map_server`` value interpretation
(wiki.ros.org/map_server "Value Interpretation", Nav2 ``map_io.cpp``):

* the image is made grey by averaging its colour channels (alpha excluded), 16-bit
  images are scaled to 0..255; ``p = (255 - v) / 255`` (or ``v / 255`` with ``negate``);
* ``trinary`` (default): ``p > occupied_thresh`` -> 100, ``p < free_thresh`` -> 0,
  otherwise -1 (unknown);
* ``scale``: the same two thresholds; in between, ``rint(100 * (p - free) / (occ - free))``,
  except that a pixel that is not fully opaque (alpha < 255) is unknown (-1) there;
* ``raw``: the grey value itself when it lies in 0..100, otherwise -1 (``negate`` ignored,
  as in Nav2).

Image row 0 is the top of the map, so rows are flipped: ``OccupancyGrid.data`` row 0 is
the row at the map origin (lowest y).  ``origin`` is ``[x, y, yaw]`` of that row's first
cell's outer corner.

``save_map`` follows Nav2 ``map_saver``: ``trinary`` writes a P5 PGM with free -> 254,
occupied -> 0, unknown -> 205 (cells ``<= rint(100 * free_thresh)`` are free, cells
``>= rint(100 * occupied_thresh)`` occupied, the rest unknown); ``raw`` writes the cell
values (unknown -> 255); ``scale`` writes a grey+alpha PNG with ``(100 - v) / 100`` grey and
unknown transparent.

The written ``free_thresh`` defaults to 0.196 (ROS 1 map_saver), not Nav2's 0.25: grey 205
means ``p = 0.19608``, which Nav2's 0.25 reloads as *free* (slam_toolbox issue #587), so
a saved map would lose its unknown space.  With 0.196 a save -> load round trip is exact.

Every problem raises :class:`~navstack.core.errors.MapFileError` with a one-line
message naming the file, the problem and the fix; YAML and Pillow exceptions never leak.
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from navstack.core.errors import MapFileError
from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose, Quaternion

MODES = ("trinary", "scale", "raw")
REQUIRED_KEYS = ("image", "resolution", "origin", "occupied_thresh", "free_thresh")
FREE_PIXEL = 254
OCCUPIED_PIXEL = 0
UNKNOWN_PIXEL = 205
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196

__all__ = ["MODES", "MapFileError", "MapImage", "load_map", "load_map_yaml", "read_image",
           "save_map"]


# --- image reading ------------------------------------------------------------------
MAX_MAP_PIXELS = 40_000_000
"""Largest map image navstack loads (e.g. 6000 x 6000 px: 300 m x 300 m at 5 cm, 1.2 km
at 20 cm).  Every layer of a costmap and the simulator's grids hold one or more arrays of
this size, so a larger map would take gigabytes and minutes per update; larger areas
need a coarser resolution or a split map.  Checked from the header, before decoding."""


def _check_size(path: Path, width: int, height: int) -> None:
    if width * height > MAX_MAP_PIXELS:
        raise MapFileError(
            f"{path}: map image is {width} x {height} = {width * height:,} pixels, more than "
            f"the limit of {MAX_MAP_PIXELS:,} (e.g. 6000 x 6000); use a coarser resolution "
            f"or split the map")
class MapImage:
    """A map image as grey values in 0..255 (float64, row 0 = top) plus alpha (0..255)."""

    __slots__ = ("alpha", "grey")

    def __init__(self, grey: NDArray[np.float64], alpha: NDArray[np.float64] | None) -> None:
        self.grey = grey
        self.alpha = alpha


_PNM_TOKEN = re.compile(rb"\s*(?:#[^\n]*\n\s*)*(\S+)")


def _pnm_header(buf: bytes, path: Path) -> tuple[bytes, int, int, int, int]:
    """Parse ``magic width height maxval`` (comments allowed); return them and data offset."""
    pos = 0
    tokens: list[bytes] = []
    while len(tokens) < 4:
        m = _PNM_TOKEN.match(buf, pos)
        if m is None:
            raise MapFileError(f"{path}: truncated PGM header; re-save the map as an 8-bit "
                               "grayscale PGM (P5) or PNG")
        tokens.append(m.group(1))
        pos = m.end()
    magic = tokens[0]
    try:
        width, height, maxval = (int(t) for t in tokens[1:])
    except ValueError:
        raise MapFileError(f"{path}: corrupt PGM header {b' '.join(tokens)!r}; re-save the "
                           "map as an 8-bit grayscale PGM (P5) or PNG") from None
    if width <= 0 or height <= 0 or not 0 < maxval < 65536:
        raise MapFileError(f"{path}: invalid PGM size {width}x{height} or maxval {maxval}; "
                           "re-save the map as an 8-bit grayscale PGM (P5) or PNG")
    return magic, width, height, maxval, pos + 1  # one whitespace byte ends the header


def _read_pgm(path: Path, buf: bytes) -> MapImage:
    """Netpbm P2 (ASCII) / P5 (binary) greymap, 8 or 16 bit, parsed with numpy."""
    magic, width, height, maxval, offset = _pnm_header(buf, path)
    _check_size(path, width, height)
    count = width * height
    if magic == b"P5":
        dtype = np.dtype(np.uint8) if maxval < 256 else np.dtype(">u2")
        if len(buf) - offset < count * dtype.itemsize:
            raise MapFileError(
                f"{path}: truncated PGM data ({len(buf) - offset} bytes for a {width}x{height} "
                "image); the file is damaged, re-save the map")
        values = np.frombuffer(buf, dtype=dtype, count=count, offset=offset)
    else:  # P2
        text = re.sub(rb"#[^\n]*", b" ", buf[offset - 1:])
        try:
            values = np.array(text.split()[:count], dtype=np.int64)
        except ValueError:
            raise MapFileError(f"{path}: non-numeric pixel in ASCII PGM data; the file is "
                               "damaged, re-save the map") from None
        if values.size < count:
            raise MapFileError(f"{path}: truncated PGM data ({values.size} of {count} pixels);"
                               " the file is damaged, re-save the map")
    grey = values.reshape(height, width).astype(np.float64)
    if maxval != 255:
        grey *= 255.0 / maxval
    return MapImage(grey, None)


def _read_pillow(path: Path) -> MapImage:
    """Any image Pillow reads (PNG, BMP, TIFF, ...): channels averaged, alpha kept."""
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():  # Pillow's bomb warning: _check_size says more
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            opened = Image.open(path)
        with opened:
            _check_size(path, *opened.size)
            opened.load()
            img: Image.Image = opened
            mode = img.mode
            if mode in ("P", "PA"):
                img = img.convert("RGBA" if "transparency" in img.info or mode == "PA" else "RGB")
            elif mode in ("1", "CMYK", "YCbCr", "LAB", "HSV"):
                img = img.convert("RGB" if mode != "1" else "L")
            arr = np.asarray(img)
            mode = img.mode
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError,
            Image.DecompressionBombError) as exc:
        raise MapFileError(f"{path}: cannot read map image ({exc}); re-save it as an 8-bit "
                           "grayscale PGM or PNG") from None
    if mode.startswith("I") or mode == "F":  # 16/32-bit grey
        data = arr.astype(np.float64)
        scale = 65535.0 if mode.startswith("I;16") or data.max(initial=0) > 255 else 255.0
        return MapImage(data * (255.0 / scale), None)
    if arr.ndim == 2:
        return MapImage(arr.astype(np.float64), None)
    has_alpha = mode in ("LA", "RGBA", "La", "RGBa")
    colour = arr[..., :-1] if has_alpha else arr
    grey = colour.astype(np.float64).mean(axis=2)
    alpha = arr[..., -1].astype(np.float64) if has_alpha else None
    return MapImage(grey, alpha)


def read_image(path: Path) -> MapImage:
    """Read a map image: P2/P5 PGM with numpy, everything else with Pillow."""
    try:
        size = path.stat().st_size
        if size > 4 * MAX_MAP_PIXELS + 2**20:  # even a 16-bit PGM at the limit is smaller
            raise MapFileError(f"{path}: map image file is {size:,} bytes, larger than any "
                               f"map of at most {MAX_MAP_PIXELS:,} pixels; use a coarser "
                               f"resolution or split the map")
        buf = path.read_bytes()
    except FileNotFoundError:
        raise MapFileError(f"{path}: image file not found") from None
    except OSError as exc:
        raise MapFileError(f"{path}: cannot read image ({exc.strerror}); check permissions") \
            from None
    if buf[:2] in (b"P2", b"P5"):
        return _read_pgm(path, buf)
    if not buf:
        raise MapFileError(f"{path}: map image is empty; re-save the map")
    return _read_pillow(path)


# --- YAML ----------------------------------------------------------------------------
def _number(doc: dict[str, Any], key: str, yaml_path: Path) -> float:
    value = doc[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapFileError(f"{yaml_path}: '{key}' must be a finite number, got {value!r}; "
                           f"fix the value of '{key}'")
    return float(value)


def load_map_yaml(yaml_path: str | Path) -> dict[str, Any]:
    """Read and validate a map_server YAML; return the normalised fields.

    Keys: ``image`` (absolute Path), ``resolution``, ``origin`` (x, y, yaw), ``negate``
    (bool), ``occupied_thresh``, ``free_thresh``, ``mode``, plus any other keys unchanged
    (map_server ignores them; navstack reads ``spawn``/``waypoints`` from them).
    """
    path = Path(yaml_path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise MapFileError(f"{path}: map YAML file not found; check the path (relative paths "
                           f"are resolved from {Path.cwd()})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise MapFileError(f"{path}: cannot read map YAML ({exc}); check the file") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise MapFileError(f"{path}: invalid YAML{where}: {problem}; fix the syntax") from None
    if not isinstance(doc, dict):
        raise MapFileError(f"{path}: a map YAML must be a mapping with keys "
                           f"{', '.join(REQUIRED_KEYS)}; got {type(doc).__name__}")
    for key in REQUIRED_KEYS:
        if key not in doc:
            raise MapFileError(f"{path}: required key '{key}' is missing; a map_server YAML "
                               f"needs {', '.join(REQUIRED_KEYS)}")
    out: dict[str, Any] = dict(doc)
    image = doc["image"]
    if not isinstance(image, str) or not image.strip():
        raise MapFileError(f"{path}: 'image' must be a file name, got {image!r}; set it to the "
                           "map image's path relative to the YAML")
    img_path = Path(image).expanduser()
    out["image"] = img_path if img_path.is_absolute() else (path.parent / img_path)
    res = _number(doc, "resolution", path)
    if res <= 0.0:
        raise MapFileError(f"{path}: resolution must be positive (got {doc['resolution']!r}); "
                           "set it to the map's metres per pixel, e.g. 0.05")
    out["resolution"] = res
    origin = doc["origin"]
    if (not isinstance(origin, list | tuple) or len(origin) != 3
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) for v in origin)):
        raise MapFileError(f"{path}: origin must be [x, y, yaw] numbers, got {origin!r}; "
                           "e.g. origin: [0.0, 0.0, 0.0]")
    out["origin"] = (float(origin[0]), float(origin[1]), float(origin[2]))
    occ, free = _number(doc, "occupied_thresh", path), _number(doc, "free_thresh", path)
    if not 0.0 <= free < occ <= 1.0:
        raise MapFileError(f"{path}: free_thresh {free} and occupied_thresh {occ} must satisfy "
                           "0 <= free_thresh < occupied_thresh <= 1; typical values are "
                           "free_thresh: 0.196, occupied_thresh: 0.65")
    out["occupied_thresh"], out["free_thresh"] = occ, free
    negate = doc.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise MapFileError(f"{path}: negate must be 0 or 1, got {negate!r}; use 0 for the usual "
                           "white-free / black-occupied images")
    out["negate"] = bool(negate)
    mode = str(doc.get("mode", "trinary")).lower()
    if mode not in MODES:
        raise MapFileError(f"{path}: unknown mode {doc.get('mode')!r}; use one of "
                           f"{', '.join(MODES)}")
    out["mode"] = mode
    return out


def _interpret(img: MapImage, meta: dict[str, Any]) -> NDArray[np.int8]:
    """Grey/alpha image (row 0 top) -> int8 occupancy (row 0 top), map_server rules."""
    grey = img.grey
    mode = meta["mode"]
    if mode == "raw":
        v = np.rint(grey)
        return np.where((v >= 0) & (v <= 100), v, -1).astype(np.int8)
    p = grey / 255.0 if meta["negate"] else (255.0 - grey) / 255.0
    occ_t, free_t = meta["occupied_thresh"], meta["free_thresh"]
    out = np.full(grey.shape, -1, dtype=np.int8)
    if mode == "scale":
        ratio = (p - free_t) / (occ_t - free_t)
        out[:] = np.clip(np.rint(100.0 * ratio), 0, 100).astype(np.int8)
        if img.alpha is not None:
            out[img.alpha < 255.0] = -1
    out[p > occ_t] = 100
    out[p < free_t] = 0
    return out


def load_map(yaml_path: str | Path, frame_id: str = "map", stamp: float = 0.0) -> OccupancyGrid:
    """Load a map_server YAML + image into an :class:`OccupancyGrid` (row 0 at the origin)."""
    meta = load_map_yaml(yaml_path)
    img_path: Path = meta["image"]
    if not img_path.is_file():
        raise MapFileError(f"{yaml_path}: image file '{img_path}' not found; the 'image' key is "
                           "resolved relative to the YAML's folder")
    img = read_image(img_path)
    if img.grey.size == 0:
        raise MapFileError(f"{img_path}: map image has no pixels; re-save the map")
    data = np.ascontiguousarray(_interpret(img, meta)[::-1])
    ox, oy, yaw = meta["origin"]
    info = MapMetaData(map_load_time=stamp, resolution=meta["resolution"],
                       width=int(data.shape[1]), height=int(data.shape[0]),
                       origin=Pose(Point(ox, oy, 0.0), Quaternion.from_yaw(yaw)))
    return OccupancyGrid(Header(stamp, frame_id), info, data)


# --- saving ----------------------------------------------------------------------------
def _fmt(x: float) -> str:
    return repr(float(x))


def _write_pgm(path: Path, pixels: NDArray[np.uint8]) -> None:
    h, w = pixels.shape
    header = f"P5\n# CREATOR: navstack map_saver\n{w} {h}\n255\n".encode()
    path.write_bytes(header + np.ascontiguousarray(pixels, dtype=np.uint8).tobytes())


def save_map(grid: OccupancyGrid, yaml_path: str | Path, mode: str = "trinary",
             occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
             free_thresh: float = DEFAULT_FREE_THRESH) -> Path:
    """Write ``grid`` as map_server YAML + image next to it (Nav2 map_saver semantics).

    The image is ``<yaml stem>.pgm`` (``.png`` for ``scale``).  Returns the image path.
    """
    path = Path(yaml_path)
    if mode not in MODES:
        raise MapFileError(f"{path}: cannot save in mode {mode!r}; use one of {', '.join(MODES)}")
    if not 0.0 <= free_thresh < occupied_thresh <= 1.0:
        raise MapFileError(f"{path}: free_thresh {free_thresh} and occupied_thresh "
                           f"{occupied_thresh} must satisfy 0 <= free_thresh < occupied_thresh "
                           "<= 1; typical values are 0.196 and 0.65")
    data = np.asarray(grid.data)
    if data.ndim != 2 or data.size == 0:
        raise MapFileError(f"{path}: cannot save an empty map (data shape {data.shape})")
    cells = data.astype(np.int16)[::-1]  # image row 0 is the top of the map
    unknown = (cells < 0) | (cells > 100)
    img_path = path.with_suffix(".png" if mode == "scale" else ".pgm")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if mode == "trinary":
            pixels = np.full(cells.shape, UNKNOWN_PIXEL, dtype=np.uint8)
            pixels[~unknown & (cells <= round(free_thresh * 100))] = FREE_PIXEL
            pixels[~unknown & (cells >= round(occupied_thresh * 100))] = OCCUPIED_PIXEL
            _write_pgm(img_path, pixels)
        elif mode == "raw":
            _write_pgm(img_path, np.where(unknown, 255, cells).astype(np.uint8))
        else:
            from PIL import Image

            grey = np.rint((100 - np.clip(cells, 0, 100)) * 2.55).astype(np.uint8)
            grey[unknown] = UNKNOWN_PIXEL
            alpha = np.where(unknown, 0, 255).astype(np.uint8)
            Image.fromarray(np.dstack((grey, alpha))).save(img_path)  # 2 channels: "LA"
        o = grid.info.origin.to_pose2d()
        path.write_text(
            f"image: {img_path.name}\n"
            f"mode: {mode}\n"
            f"resolution: {_fmt(grid.info.resolution)}\n"
            f"origin: [{_fmt(o.x)}, {_fmt(o.y)}, {_fmt(o.theta)}]\n"
            f"negate: 0\n"
            f"occupied_thresh: {_fmt(occupied_thresh)}\n"
            f"free_thresh: {_fmt(free_thresh)}\n")
    except OSError as exc:
        raise MapFileError(f"{path}: cannot write map ({exc.strerror}); check that the folder "
                           "is writable") from None
    return img_path

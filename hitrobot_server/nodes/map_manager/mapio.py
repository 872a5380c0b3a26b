"""The files of a map folder (pure conversions, bytes in and out).

``map.yaml`` + ``map.pgm``
    the robot's map exactly as ROS ``map_server``/``map_saver`` write it: a binary (P5) PGM,
    row 0 at the top (maximum y), trinary values occupied 0, free 254, unknown 205, and the
    YAML ``image``, ``resolution``, ``origin [x, y, yaw]``, ``negate 0``,
    ``occupied_thresh 0.65``, ``free_thresh 0.196``, ``mode trinary``.
``masks.yaml`` + ``mask_<layer>.png``
    the user masks of each layer that has any: an 8-bit grayscale PNG per layer, laid out like
    a map_server image (row 0 at the top, its own ``resolution`` and ``origin``), with the pixel
    values listed in the YAML (``values``): not masked 205, FREE 254, OBSTACLE 128, BLOCKED 0,
    so the image reads like a map (blocked black, free white).
``pois.yaml``
    the POIs: ``pois: [{name, type, remarks, pose: {position: {x, y, z}, orientation: {x, y, z,
    w}}}]``.
``robot.yaml``
    what else the robot's map carries: virtual walls and tracks and the home dock pose.

Reading follows map_server's rules (``negate``, thresholds, ``trinary``/``scale``/``raw``), so a
map folder written by map_saver loads too.
"""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np
import yaml
from PIL import Image

from .layers import (
    BLOCKED,
    FREE,
    LAYER_NAMES,
    NOT_MASKED,
    OBSTACLE,
    Grid,
    LayerError,
    Mask,
)

MAP_YAML, MAP_IMAGE = "map.yaml", "map.pgm"
MASKS_YAML, POIS_YAML, ROBOT_YAML = "masks.yaml", "pois.yaml", "robot.yaml"
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196
PGM_OCCUPIED, PGM_FREE, PGM_UNKNOWN = 0, 254, 205
MASK_PIXELS = {NOT_MASKED: 205, FREE: 254, OBSTACLE: 128, BLOCKED: 0}
MAX_IMAGE_PIXELS = 64_000_000


class MapFileError(ValueError):
    """A map folder file that cannot be read; the text is user-facing."""


def _yaml(data: bytes, what: str) -> dict:
    try:
        doc = yaml.safe_load(data.decode("utf-8"))
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise MapFileError(f"{what} is not valid YAML: {exc}") from None
    if not isinstance(doc, dict):
        raise MapFileError(f"{what} must be a YAML mapping")
    return doc


def _float(doc: dict, key: str, what: str) -> float:
    value = doc.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapFileError(f"{what}: '{key}' must be a finite number")
    return float(value)


def _origin(doc: dict, what: str) -> tuple[float, float, float]:
    origin = doc.get("origin")
    if (not isinstance(origin, list) or len(origin) != 3
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) for v in origin)):
        raise MapFileError(f"{what}: 'origin' must be [x, y, yaw]")
    return float(origin[0]), float(origin[1]), float(origin[2])


def _image_name(doc: dict, what: str) -> str:
    name = doc.get("image")
    if not isinstance(name, str) or not name or "/" in name or "\\" in name or name[0] == ".":
        raise MapFileError(f"{what}: 'image' must be a file name in the map folder")
    return name


def _decode_image(data: bytes, what: str) -> np.ndarray:
    try:
        with Image.open(io.BytesIO(data)) as image:
            if image.width * image.height > MAX_IMAGE_PIXELS:
                raise MapFileError(f"{what} is too large")
            pixels = np.asarray(image.convert("L"), dtype=np.uint8)
    except MapFileError:
        raise
    except Exception as exc:
        raise MapFileError(f"{what} is not a readable image: {exc}") from None
    if pixels.size == 0:
        raise MapFileError(f"{what} is empty")
    return pixels


def _float_text(value: float) -> str:
    return repr(float(value))


# ---------------------------------------------------------------------------------- the map
def occupancy_to_pgm(data: np.ndarray) -> np.ndarray:
    """ROS occupancy (row 0 at the minimum y) to map_saver's trinary image (row 0 at the top);
    thresholds as map_saver's: >= 65 occupied, 0..25 free, the rest unknown."""
    data = np.asarray(data, dtype=np.int16)
    image = np.full(data.shape, PGM_UNKNOWN, dtype=np.uint8)
    image[(data >= 0) & (data <= 25)] = PGM_FREE
    image[data >= 65] = PGM_OCCUPIED
    return np.flipud(image)


def encode_map(grid: Grid, image_name: str = MAP_IMAGE) -> tuple[bytes, bytes]:
    """(YAML bytes, PGM bytes) of ``grid``."""
    out = io.BytesIO()
    Image.fromarray(occupancy_to_pgm(grid.data), mode="L").save(out, format="PPM")
    text = (
        f"image: {image_name}\n"
        f"resolution: {_float_text(grid.resolution)}\n"
        f"origin: [{_float_text(grid.origin_x)}, {_float_text(grid.origin_y)}, 0.0]\n"
        "negate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH}\n"
        f"free_thresh: {FREE_THRESH}\n"
        "mode: trinary\n"
    )
    return text.encode(), out.getvalue()


def map_image_name(yaml_bytes: bytes) -> str:
    return _image_name(_yaml(yaml_bytes, MAP_YAML), MAP_YAML)


def decode_map(yaml_bytes: bytes, image_bytes: bytes) -> Grid:
    """A map_server map (YAML + image) as an occupancy grid, by map_server's rules."""
    doc = _yaml(yaml_bytes, MAP_YAML)
    _image_name(doc, MAP_YAML)
    resolution = _float(doc, "resolution", MAP_YAML)
    if resolution <= 0:
        raise MapFileError(f"{MAP_YAML}: 'resolution' must be positive")
    ox, oy, _yaw = _origin(doc, MAP_YAML)
    negate = doc.get("negate", 0)
    if negate not in (0, 1, True, False):
        raise MapFileError(f"{MAP_YAML}: 'negate' must be 0 or 1")
    occ = _float(doc, "occupied_thresh", MAP_YAML) if "occupied_thresh" in doc else 0.65
    free = _float(doc, "free_thresh", MAP_YAML) if "free_thresh" in doc else 0.196
    mode = doc.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise MapFileError(f"{MAP_YAML}: 'mode' must be trinary, scale or raw")
    pixels = _decode_image(image_bytes, "the map image").astype(np.float64)
    if mode == "raw":
        data = np.clip(pixels, -1, 100)
        data = np.where(pixels > 100, -1, data)
    else:
        p = pixels / 255.0 if negate else (255.0 - pixels) / 255.0
        data = np.full(pixels.shape, -1.0)
        data[p > occ] = 100
        data[p < free] = 0
        if mode == "scale":
            between = (p >= free) & (p <= occ)
            data[between] = np.rint(99.0 * (p[between] - free) / (occ - free))
    grid = np.flipud(data).astype(np.int8)
    return Grid(ox, oy, resolution, np.ascontiguousarray(grid))


# ---------------------------------------------------------------------------------- masks
def encode_masks(masks: dict[int, Mask]) -> dict[str, bytes]:
    """``masks.yaml`` and one PNG per layer that has masks (always the YAML, maybe empty)."""
    files: dict[str, bytes] = {}
    entries = []
    for layer, mask in sorted(masks.items()):
        if mask.empty:
            continue
        name = f"mask_{LAYER_NAMES[layer].lower()}.png"
        pixels = np.full(mask.cells.shape, MASK_PIXELS[NOT_MASKED], dtype=np.uint8)
        for value, pixel in MASK_PIXELS.items():
            pixels[mask.cells == value] = pixel
        out = io.BytesIO()
        Image.fromarray(np.flipud(pixels), mode="L").save(out, format="PNG")
        files[name] = out.getvalue()
        ox, oy = mask.origin
        entries.append({"layer": layer, "name": LAYER_NAMES[layer], "image": name,
                        "resolution": mask.resolution, "origin": [ox, oy, 0.0]})
    doc = {"values": {"not_masked": MASK_PIXELS[NOT_MASKED], "free": MASK_PIXELS[FREE],
                      "obstacle": MASK_PIXELS[OBSTACLE], "blocked": MASK_PIXELS[BLOCKED]},
           "layers": entries}
    header = "# hitrobot map manager: user masks per map layer (map_messages/ModifyMap)\n"
    files[MASKS_YAML] = (header + yaml.safe_dump(doc, sort_keys=False)).encode()
    return files


def mask_images(yaml_bytes: bytes) -> list[str]:
    doc = _yaml(yaml_bytes, MASKS_YAML)
    layers = doc.get("layers") or []
    if not isinstance(layers, list):
        raise MapFileError(f"{MASKS_YAML}: 'layers' must be a list")
    return [_image_name(e, MASKS_YAML) if isinstance(e, dict) else "" for e in layers]


def decode_masks(yaml_bytes: bytes, images: dict[str, bytes]) -> dict[int, Mask]:
    doc = _yaml(yaml_bytes, MASKS_YAML)
    values = doc.get("values", {})
    keys = {"not_masked": NOT_MASKED, "free": FREE, "obstacle": OBSTACLE, "blocked": BLOCKED}
    if not isinstance(values, dict):
        raise MapFileError(f"{MASKS_YAML}: 'values' must be a mapping")
    pixel_to_value: dict[int, int] = {}
    for key, value in keys.items():
        pixel = values.get(key, MASK_PIXELS[value])
        if isinstance(pixel, bool) or not isinstance(pixel, int) or not 0 <= pixel <= 255:
            raise MapFileError(f"{MASKS_YAML}: 'values.{key}' must be a pixel value 0-255")
        if pixel in pixel_to_value:
            raise MapFileError(f"{MASKS_YAML}: two mask values share pixel {pixel}")
        pixel_to_value[pixel] = value
    out: dict[int, Mask] = {}
    layers = doc.get("layers") or []
    if not isinstance(layers, list):
        raise MapFileError(f"{MASKS_YAML}: 'layers' must be a list")
    for entry in layers:
        if not isinstance(entry, dict):
            raise MapFileError(f"{MASKS_YAML}: each layer must be a mapping")
        layer = entry.get("layer")
        if layer not in LAYER_NAMES or isinstance(layer, bool):
            raise MapFileError(f"{MASKS_YAML}: unknown layer {layer!r}")
        if layer in out:
            raise MapFileError(f"{MASKS_YAML}: layer {layer} appears twice")
        resolution = _float(entry, "resolution", MASKS_YAML)
        if resolution <= 0:
            raise MapFileError(f"{MASKS_YAML}: 'resolution' must be positive")
        ox, oy, _yaw = _origin(entry, MASKS_YAML)
        name = _image_name(entry, MASKS_YAML)
        if name not in images:
            raise MapFileError(f"{MASKS_YAML}: image {name!r} is missing")
        pixels = np.flipud(_decode_image(images[name], name))
        cells = np.full(pixels.shape, NOT_MASKED, dtype=np.int8)
        unknown = np.ones(pixels.shape, dtype=bool)
        for pixel, value in pixel_to_value.items():
            hit = pixels == pixel
            cells[hit] = value
            unknown &= ~hit
        if unknown.any():
            raise MapFileError(f"{name}: pixel values other than those in 'values'")
        try:
            out[layer] = Mask.from_cells(resolution, round(ox / resolution),
                                         round(oy / resolution), cells)
        except LayerError as exc:
            raise MapFileError(f"{name}: {exc}") from None
    return out


# ---------------------------------------------------------------------------------- POIs
def encode_pois(pois: list[dict]) -> bytes:
    header = "# hitrobot map manager: points of interest (map_messages/PointOfInterest)\n"
    return (header + yaml.safe_dump({"pois": pois}, sort_keys=False,
                                    allow_unicode=True)).encode()


def decode_pois(data: bytes) -> list[dict]:
    """The raw POI list (validate with :class:`~.pois.PoiRegistry`)."""
    doc = _yaml(data, POIS_YAML)
    pois = doc.get("pois") or []
    if not isinstance(pois, list):
        raise MapFileError(f"{POIS_YAML}: 'pois' must be a list")
    return pois


# ---------------------------------------------------------------------------------- robot
def encode_robot(walls: list[Any], tracks: list[Any], home: Any) -> bytes:
    """Lines as ``{id, start: [x, y], end: [x, y]}``, home as ``[x, y, yaw]`` or null."""
    def lines(items):
        return [{"id": int(ln.id), "start": [float(ln.start.x), float(ln.start.y)],
                 "end": [float(ln.end.x), float(ln.end.y)]} for ln in items]

    doc = {"virtual_walls": lines(walls), "virtual_tracks": lines(tracks),
           "home": None if home is None else [float(home.x), float(home.y), float(home.yaw)]}
    header = "# hitrobot map manager: virtual walls, virtual tracks and the home dock pose\n"
    return (header + yaml.safe_dump(doc, sort_keys=False)).encode()


def decode_robot(data: bytes) -> dict:
    """``{"virtual_walls": [(id, x0, y0, x1, y1)], "virtual_tracks": [...],
    "home": (x, y, yaw) | None}``."""
    doc = _yaml(data, ROBOT_YAML)

    def finite(values: Any, n: int, what: str) -> tuple[float, ...]:
        if (not isinstance(values, list) or len(values) != n
                or not all(isinstance(v, int | float) and not isinstance(v, bool)
                           and math.isfinite(v) for v in values)):
            raise MapFileError(f"{ROBOT_YAML}: {what} must be {n} finite numbers")
        return tuple(float(v) for v in values)

    out: dict[str, Any] = {}
    for key in ("virtual_walls", "virtual_tracks"):
        items = doc.get(key) or []
        if not isinstance(items, list):
            raise MapFileError(f"{ROBOT_YAML}: '{key}' must be a list")
        parsed = []
        for item in items:
            if not isinstance(item, dict) or isinstance(item.get("id"), bool) \
                    or not isinstance(item.get("id"), int):
                raise MapFileError(f"{ROBOT_YAML}: each of '{key}' needs an integer 'id'")
            parsed.append((item["id"], *finite(item.get("start"), 2, f"{key} start"),
                           *finite(item.get("end"), 2, f"{key} end")))
        out[key] = parsed
    home = doc.get("home")
    out["home"] = None if home is None else finite(home, 3, "'home'")
    return out

"""The simulated robot's true surroundings, loaded from a ROS ``map_server`` YAML + image.

Any map_server map works (``--world FILE``). Two optional extra YAML keys place the robot:
``start_pose: [x, y, yaw]`` and ``dock_pose: [x, y, yaw]`` (the pose the robot has when sitting
on its charging dock, facing away from it). Unknown cells of the image are treated as solid:
nothing is known to be passable there, so the simulated robot can neither see nor drive into it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from PIL import Image

from ..model import Pose2D
from ..planning.grid import GridSpec, distance_field

DEFAULT_WORLD = Path(__file__).resolve().parent.parent / "worlds" / "office.yaml"
"""The office world shipped with the package."""


@dataclass(frozen=True, slots=True, eq=False)
class World:
    """Ground truth: occupancy (row 0 at min y), the robot's start pose and its dock."""

    name: str
    spec: GridSpec
    occupied: np.ndarray
    unknown: np.ndarray
    start_pose: Pose2D
    dock_pose: Pose2D | None

    @property
    def solid(self) -> np.ndarray:
        """Cells the robot cannot enter and the lidar cannot see through."""
        return self.occupied | self.unknown

    @property
    def free(self) -> np.ndarray:
        return ~self.solid


def load_world(path: str | Path = DEFAULT_WORLD) -> World:
    """Load a map_server YAML file and the image it names.

    Raises ``ValueError`` for a malformed file or a rotated origin (map_server allows a yaw
    in ``origin``; nothing here needs it, so it is refused rather than silently ignored).
    """
    path = Path(path)
    meta = parse_map_yaml(path.read_text(encoding="utf-8"))
    try:
        image_name = str(meta["image"])
        resolution = float(meta["resolution"])  # type: ignore[arg-type]
        origin = [float(v) for v in meta["origin"]]  # type: ignore[union-attr]
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{path}: needs image, resolution and origin [x, y, yaw]") from exc
    if len(origin) != 3:
        raise ValueError(f"{path}: origin must be [x, y, yaw]")
    if abs(origin[2]) > 1e-9:
        raise ValueError(f"{path}: rotated map origins are not supported")
    negate = bool(int(meta.get("negate", 0)))  # type: ignore[arg-type]
    occupied_thresh = float(meta.get("occupied_thresh", 0.65))  # type: ignore[arg-type]
    free_thresh = float(meta.get("free_thresh", 0.196))  # type: ignore[arg-type]
    mode = str(meta.get("mode", "trinary"))

    image = Image.open(path.parent / image_name)
    alpha = None
    if image.mode in ("RGBA", "LA", "PA"):
        alpha = np.asarray(image.getchannel("A"))
    pixels = np.asarray(image.convert("L")).astype(np.float64)
    if mode == "raw":
        occupancy = pixels / 100.0
        unknown_raw = pixels > 100.0
    elif mode in ("trinary", "scale"):
        occupancy = pixels / 255.0 if negate else (255.0 - pixels) / 255.0
        unknown_raw = np.zeros(pixels.shape, dtype=bool)
    else:
        raise ValueError(f"{path}: unknown mode {mode!r}")
    occupied = (occupancy > occupied_thresh) & ~unknown_raw
    free = (occupancy < free_thresh) & ~unknown_raw
    if alpha is not None:
        occupied &= alpha > 0
        free &= alpha > 0
    # Images list the top row first; grids keep row 0 at the minimum y.
    occupied = np.ascontiguousarray(occupied[::-1])
    free = np.ascontiguousarray(free[::-1])
    unknown = ~(occupied | free)
    height, width = occupied.shape
    spec = GridSpec(origin[0], origin[1], resolution, width, height)
    dock = _pose(meta, "dock_pose", path)
    start = _pose(meta, "start_pose", path) or dock or _roomiest_pose(spec, occupied | unknown)
    return World(path.stem, spec, occupied, unknown, start, dock)


def parse_map_yaml(text: str) -> dict[str, object]:
    """Parse a map_server YAML file (PyYAML ``safe_load``); it must be a mapping."""
    try:
        meta = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"invalid YAML: {exc}") from None
    if not isinstance(meta, dict):
        raise ValueError("expected a mapping of 'key: value' lines")
    return meta


def _pose(meta: dict[str, object], key: str, path: Path) -> Pose2D | None:
    value = meta.get(key)
    if value is None:
        return None
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError(f"{path}: {key} must be [x, y, yaw]")
    try:
        return Pose2D(*(float(v) for v in value))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {key} must be numbers") from exc


def _roomiest_pose(spec: GridSpec, solid: np.ndarray) -> Pose2D:
    """A start pose when the YAML names none: the free cell farthest from any obstacle."""
    clearance = distance_field(solid, 40)
    row, col = np.unravel_index(int(np.argmax(clearance)), clearance.shape)
    x, y = spec.center(col, row)
    return Pose2D(float(x), float(y), 0.0)

"""The points of interest (pure): a registry of ``map_messages/PointOfInterest`` keyed by name.

POIs are distinguished by their name, so names are unique and must not be empty; the type is
one of the message's constants; the pose must be finite. Every refused request raises
:class:`PoiError` and leaves the registry exactly as it was. POIs keep the order they were added
in (a modified POI keeps its place).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

Check = Callable[[dict, dict | None], None]
"""A last check of a valid POI (and the one it replaces) before it is stored; raises PoiError."""

POI_TYPES = {
    100: "DEFAULT",
    200: "VICTIM",
    300: "OBJECT",
    400: "GRIPPABLE_OBJECT",
    600: "PERSON",
    700: "ROOMBA",
    800: "HAZARD_MATERIAL",
    900: "START_POSITION",
    1000: "START_ORIENTATION",
}
MAX_NAME_LENGTH = 256
MAX_POIS = 10_000


class PoiError(ValueError):
    """A refused POI request; the text is user-facing."""


def _number(value: Any, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise PoiError(f"field '{path}' must be a finite number")
    return float(value)


def normalize(poi: dict, path: str = "poi") -> dict:
    """A validated copy of a PointOfInterest dict (plain Python numbers and strings)."""
    try:
        kind, name, remarks, pose = poi["type"], poi["name"], poi["remarks"], poi["pose"]
        position, orientation = pose["position"], pose["orientation"]
    except (KeyError, TypeError):
        raise PoiError(f"'{path}' is not a PointOfInterest") from None
    if not isinstance(name, str) or not name.strip():
        raise PoiError(f"field '{path}.name' must not be empty")
    if len(name) > MAX_NAME_LENGTH:
        raise PoiError(f"field '{path}.name' is longer than {MAX_NAME_LENGTH} characters")
    if isinstance(kind, bool) or not isinstance(kind, int) or kind not in POI_TYPES:
        names = ", ".join(f"{v}={k}" for k, v in POI_TYPES.items())
        raise PoiError(f"field '{path}.type' must be one of {names}, got {kind!r}")
    if not isinstance(remarks, str):
        raise PoiError(f"field '{path}.remarks' must be a string")
    return {
        "type": int(kind),
        "name": name,
        "remarks": remarks,
        "pose": {
            "position": {k: _number(position[k], f"{path}.pose.position.{k}") for k in "xyz"},
            "orientation": {k: _number(orientation[k], f"{path}.pose.orientation.{k}")
                            for k in "xyzw"},
        },
    }


def _copy(poi: dict) -> dict:
    """A copy of a normalized POI, field by field: its shape is fixed, and ``deepcopy`` cost
    20 µs a POI, which every add paid for each POI twice (the list kept and published)."""
    pose = poi["pose"]
    return {"type": poi["type"], "name": poi["name"], "remarks": poi["remarks"],
            "pose": {"position": dict(pose["position"]),
                     "orientation": dict(pose["orientation"])}}


class PoiRegistry:
    """Unique-named POIs in insertion order."""

    def __init__(self) -> None:
        self._pois: dict[str, dict] = {}
        self.revision = 0

    def __len__(self) -> int:
        return len(self._pois)

    def __contains__(self, name: object) -> bool:
        return name in self._pois

    def get(self, name: str) -> dict | None:
        poi = self._pois.get(name)
        return None if poi is None else _copy(poi)

    def all(self) -> list[dict]:
        return [_copy(p) for p in self._pois.values()]

    def add(self, poi: dict, check: Check | None = None) -> dict:
        clean = normalize(poi)
        if clean["name"] in self._pois:
            raise PoiError(f"a POI named {clean['name']!r} already exists")
        if len(self._pois) >= MAX_POIS:
            raise PoiError(f"there are already {MAX_POIS} POIs")
        if check:
            check(clean, None)
        self._pois[clean["name"]] = clean
        self.revision += 1
        return _copy(clean)

    def modify(self, old_name: str, poi: dict, check: Check | None = None) -> dict:
        if old_name not in self._pois:
            raise PoiError(f"there is no POI named {old_name!r}")
        clean = normalize(poi)
        new_name = clean["name"]
        if new_name != old_name and new_name in self._pois:
            raise PoiError(f"cannot rename {old_name!r}: a POI named {new_name!r} already exists")
        if check:
            check(clean, self._pois[old_name])
        self._pois = {(new_name if k == old_name else k): (clean if k == old_name else v)
                      for k, v in self._pois.items()}
        self.revision += 1
        return _copy(clean)

    def delete(self, name: str) -> None:
        if name not in self._pois:
            raise PoiError(f"there is no POI named {name!r}")
        del self._pois[name]
        self.revision += 1

    def replace_all(self, pois: list[dict]) -> None:
        """Install a whole list (validated first: on any error nothing changes)."""
        fresh: dict[str, dict] = {}
        for i, poi in enumerate(pois):
            clean = normalize(poi, f"pois[{i}]")
            if clean["name"] in fresh:
                raise PoiError(f"POI name {clean['name']!r} appears twice")
            fresh[clean["name"]] = clean
        if len(fresh) > MAX_POIS:
            raise PoiError(f"more than {MAX_POIS} POIs")
        self._pois = fresh
        self.revision += 1

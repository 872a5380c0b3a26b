"""The map manager's sections of the robot's state folder: its POIs, layer switches, masks and
which saved map is loaded.

A section that does not check out when it comes back is skipped (and kept aside by the store);
the others still apply. A change the store could not write is taken back (:meth:`take_back`).
"""

from __future__ import annotations

import io

import numpy as np

from ..ground.memory import NodeMemory, kept
from .composition import MapComposition
from .layers import DEFAULT_STATES, LAYER_NAMES, LayerError, Mask
from .pois import PoiError, PoiRegistry


def encode_masks(masks: dict[int, Mask]) -> bytes:
    """The masks for the state store: one ``.npz`` (no pickles) of cells and placement."""
    arrays: dict[str, np.ndarray] = {}
    for layer, mask in masks.items():
        arrays[f"cells_{layer}"] = mask.cells
        arrays[f"place_{layer}"] = np.array([mask.resolution, mask.col0, mask.row0])
    out = io.BytesIO()
    np.savez(out, **arrays)
    return out.getvalue()


def decode_masks(data: bytes) -> dict[int, Mask]:
    """What :func:`encode_masks` wrote; LayerError (or ValueError) if it is not that."""
    masks: dict[int, Mask] = {}
    with np.load(io.BytesIO(data), allow_pickle=False) as arrays:
        for name in arrays.files:
            if not name.startswith("cells_"):
                continue
            layer = int(name.removeprefix("cells_"))
            if layer not in LAYER_NAMES:
                raise LayerError(f"unknown layer {layer}")
            resolution, col0, row0 = arrays[f"place_{layer}"].tolist()
            masks[layer] = Mask.from_cells(resolution, int(col0), int(row0), arrays[name])
    return masks


class Sections:
    """Puts the POIs, the layer switches and the masks into the state folder, and takes them
    back from it."""

    def __init__(self, memory: NodeMemory, pois: PoiRegistry, layers: MapComposition):
        self.memory, self.pois, self.layers = memory, pois, layers
        self.loaded = ""
        """The saved map last loaded ("" for none): the console marks it "· loaded"."""

    def restore(self) -> None:
        """POIs, layer switches, masks and the loaded map as the state store kept them."""
        pois, layers, masks = (self.memory.get(k) for k in ("pois", "layers", "masks"))
        self.pois.replace_all([])
        self.layers.states, self.layers.masks = dict(DEFAULT_STATES), {}
        loaded = self.memory.get("loaded")
        self.loaded = loaded if isinstance(loaded, str) else ""
        if pois is not None:
            try:
                if not isinstance(pois, list):
                    raise PoiError("not a list of POIs")
                self.pois.replace_all(pois)
            except PoiError as exc:
                self.memory.reject("pois", str(exc))
        if layers is not None:
            try:
                states = {int(k): v for k, v in layers.items()}
                if not set(states) <= set(LAYER_NAMES) or not all(
                        isinstance(v, bool) for v in states.values()):
                    raise ValueError("unknown layers or non-boolean states")
                self.layers.states.update(states)
            except (AttributeError, ValueError) as exc:
                self.memory.reject("layers", str(exc))
        if masks is not None:
            try:
                self.layers.masks = decode_masks(masks)
            except (LayerError, ValueError, KeyError, OSError) as exc:
                self.memory.reject("masks", str(exc))

    def take_back(self) -> None:
        """A change that could not be written: the POIs, layer switches, masks and loaded map
        as the state folder has them (the store answers what is on disk again)."""
        self.restore()

    def remember(self, *what: str) -> None:
        """Put the named sections (pois, layers, masks, loaded) into the state store."""
        for name in what:
            if name == "pois":
                self.memory.put("pois", self.pois.all())
            elif name == "loaded":
                self.memory.put("loaded", self.loaded or None)
            elif name == "layers":
                self.memory.put("layers", {str(k): v for k, v in self.layers.states.items()})
            else:
                masks = self.layers.masks
                self.memory.put("masks", encode_masks(masks) if masks else None)

    def restored(self) -> list[str]:
        """What came back from the state folder, for the start-up log."""
        if self.memory.store is None:
            return []
        phrases = [] if not self.pois else [f"{len(self.pois)} POIs"]
        if self.layers.masks:
            phrases.append(f"masks on {len(self.layers.masks)} layers")
        return phrases

    async def kept(self, what: str) -> None:
        """Once request ``what``'s change is kept, as the acknowledgement table says (every
        map-manager change: on disk); ``NotSaved`` when the disk refused it."""
        await kept(what, self._on_disk)

    async def _on_disk(self) -> str:
        await self.memory.durable()
        return ""

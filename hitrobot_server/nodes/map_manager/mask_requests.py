"""``map_layers`` and ``modify_map``: the user's layer switches and masks. Both change ``/map``
at once and hand the robot the new blocked areas."""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable

from ...bus.topics import Message, RequestRejected
from ...robot.backend import BackendError
from ..base import RobotNode
from ..ground.memory import NotSaved
from .composition import MapComposition
from .jobs import job
from .layers import LAYER_NAMES, MASK_ACTIONS, LayerError, Mask
from .sections import Sections
from .topics import PKG, request_topic

log = logging.getLogger(__name__)


def _one_of(what: str, field: str, value: int, names: dict[int, str]) -> None:
    if value not in names:
        listed = ", ".join(f"{v}={k}" for k, v in names.items())
        raise RequestRejected(f"{what}: field '{field}' must be one of {listed}, got {value}")


class MaskRequests:
    """Layer switches and mask painting on the composition, remembered in the state folder."""

    def __init__(self, node: RobotNode, layers: MapComposition, sections: Sections):
        self.node, self.layers, self.sections = node, layers, sections

    def listen(self) -> None:
        self.node.subscribe(request_topic("map_layers"), f"{PKG}/MapLayers", self._on_map_layers)
        self.node.subscribe(request_topic("modify_map"), f"{PKG}/ModifyMap", self._on_modify_map)

    def _on_map_layers(self, message: Message) -> None:
        layer, state = message.msg["layer"], bool(message.msg["state"])
        _one_of("map_layers", "layer", layer, LAYER_NAMES)
        self.layers.states[layer] = state
        self.sections.remember("layers")
        self.layers.publish_map(force=True)
        text = f"{LAYER_NAMES[layer]} {'on' if state else 'off'}"
        job(self.node, message, "map_layers", self._push_then("map_layers", text),
            needs_robot=False)

    def _on_modify_map(self, message: Message) -> None:
        msg = message.msg
        layer, action = msg["mapLayer"], msg["maskAction"]
        _one_of("modify_map", "mapLayer", layer, LAYER_NAMES)
        _one_of("modify_map", "maskAction", action, MASK_ACTIONS)
        polygon = [(float(p["x"]), float(p["y"])) for p in msg["region"]]
        masks = self.layers.masks
        mask = masks.get(layer) or Mask(self.layers.resolution())
        try:
            cells = mask.paint(polygon, action)
        except LayerError as exc:
            raise RequestRejected(f"modify_map: {exc}") from None
        if mask.empty:
            masks.pop(layer, None)
        else:
            masks[layer] = mask
        self.sections.remember("masks")
        try:
            self.layers.publish_map(force=True)
        except LayerError as exc:
            log.warning("/map: %s", exc)
        text = f"{MASK_ACTIONS[action]} {cells} cells of {LAYER_NAMES[layer]}"
        job(self.node, message, "modify_map", self._push_then("modify_map", text),
            needs_robot=False)

    def _push_then(self, what: str, text: str | None) -> Callable[[], Awaitable[str | None]]:
        async def work() -> str | None:
            try:
                await self.sections.kept(what)
            except NotSaved as exc:  # the mask or switch is taken back: /map as on disk
                self.sections.take_back()
                try:
                    self.layers.publish_map(force=True)
                except LayerError as error:
                    log.warning("/map: %s", error)
                raise NotSaved(f"{exc}; the change was taken back") from None
            try:
                await self.layers.push_blocked()
            except BackendError as exc:
                raise BackendError(f"the robot did not take the blocked areas ({exc}); "
                                   "retrying") from None
            return text
        return work

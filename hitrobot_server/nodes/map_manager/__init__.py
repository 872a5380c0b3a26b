"""``/map_manager``: POIs, map layers and masks, the composed ``/map``, and map folders."""

from .node import MEMORY, NODE_NAME, MapManager

__all__ = ["MEMORY", "NODE_NAME", "MapManager"]

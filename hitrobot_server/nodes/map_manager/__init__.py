"""``/map_manager``: POIs, map layers and masks, the composed ``/map``, and map folders."""

from .node import NODE_NAME, MapManager

__all__ = ["NODE_NAME", "MapManager"]

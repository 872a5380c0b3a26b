"""The map manager's names on the bus, shared by its parts (the names other nodes use to reach
it are in :mod:`..ground.names`)."""

from ..ground import names
from ..ground.names import MAP_MANAGER, MAP_MANAGER_LOADED_MAP

NODE_NAME = MAP_MANAGER
PKG = "map_messages"
MAP_TOPIC = names.MAP_TOPIC
MAP_FRAME = "/map"
POIS_TOPIC = f"{NODE_NAME}/pois"
HOME_TOPIC = f"{NODE_NAME}/home"
LOADED_TOPIC = MAP_MANAGER_LOADED_MAP


def request_topic(name: str) -> str:
    """One of the map manager's request topics (``/map_manager/NAME``)."""
    return f"{NODE_NAME}/{name}"

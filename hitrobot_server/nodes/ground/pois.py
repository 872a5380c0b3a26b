"""Reading the map manager's points of interest: the one way every other node does it, over
the bus (its ``get_pois`` service), so a node needs no handle on the map manager and a site
node (the fleet) reads the site's POIs like a robot's node (navigation) does."""

from __future__ import annotations

from ...bus.core import Bus
from .names import MAP_MANAGER_GET_POIS

POI_TIMEOUT = 5.0
"""Seconds the map manager has to list its POIs."""


async def find_poi(bus: Bus, name: str) -> dict | None:
    """The POI named ``name`` (a ``map_messages/PointOfInterest`` dict), None when there is
    none; the bus's ServiceError (or another exception) when the POIs cannot be read."""
    reply = await bus.call_service(MAP_MANAGER_GET_POIS, {}, timeout=POI_TIMEOUT)
    for poi in reply["poi_list"]["pois"]:
        if poi["name"] == name:
            return poi
    return None

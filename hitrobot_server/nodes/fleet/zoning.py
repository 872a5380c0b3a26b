"""``/fleet/zone_add`` (``hitrobot_msgs/FleetZoneAdd``), ``/fleet/zone_list``
(``FleetZoneList``), ``/fleet/zone_remove`` (``FleetZoneRemove``), ``/fleet/zone_release``
(``FleetZoneRemove``: the zone's offline holders let go, with a warning) and the latched
``/fleet/zones`` (``FleetZones``: each zone with who holds it and who waits, in order): the
site's mutex zones, kept in the state folder (``fleet/zones``). A change is written before it
applies (one the disk refuses changes nothing) and answered as :mod:`..ground.acks` says; the
changes take turns (checked, written, applied one at a time), so adds sent back to back pass
the bound of :data:`.zones.MAX_ZONES` no further than one at a time would, and each one written
holds every zone before it. A kept add costs about 3 ms of the loop (its checks, one journal
line of the zones, the ``/fleet/zones`` publish) and one fsync waited in turn; a refused one
about 0.1 ms."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable

from ..ground.memory import NodeMemory, NotSaved
from .member import OFFLINE, PKG
from .roster import Roster
from .tasks import Refused
from .traffic import Traffic
from .zones import Zone, checked_zone

log = logging.getLogger(__name__)

ZONES = "/fleet/zones"
SECTION = "zones"


class ZoneServices:
    """The zones' services on the robots' ``roster``, the site map given by ``site_map``;
    ``serve``, ``advertise`` and ``publish`` are the fleet node's (offered while it leads)."""

    def __init__(self, memory: NodeMemory, roster: Roster,
                 site_map: Callable[[], dict | None], serve: Callable[..., None],
                 advertise: Callable[..., None], publish: Callable[[str, dict], object]):
        self.memory, self.roster, self.site_map, self._publish = memory, roster, site_map, publish
        self.traffic = Traffic(roster.pose_of, self.publish)
        self._turn = asyncio.Lock()  # one change at a time: checked, written, applied
        advertise(ZONES, f"{PKG}/FleetZones", latch=True)
        for name, kind, handler in (("zone_add", "FleetZoneAdd", self._add),
                                    ("zone_list", "FleetZoneList", self._list),
                                    ("zone_remove", "FleetZoneRemove", self._remove),
                                    ("zone_release", "FleetZoneRemove", self._release)):
            serve(f"/fleet/{name}", f"{PKG}/{kind}", handler)

    def restore(self) -> list[str]:
        try:
            for record in self.memory.get(SECTION) or []:
                self.traffic.put(Zone.from_record(record))
        except (KeyError, ValueError, TypeError) as exc:
            self.memory.reject(SECTION, str(exc))
        return [f"{len(self.traffic.zones)} mutex zones"] if self.traffic.zones else []

    def reload(self) -> None:
        """The zones as kept (a copy from the dispatcher we follow): the traffic takes them."""
        kept = {}
        for record in self.memory.get(SECTION) or []:
            with contextlib.suppress(KeyError, ValueError, TypeError):
                zone = Zone.from_record(record)
                kept[zone.name] = zone
        for name in set(self.traffic.zones) - set(kept):
            self.traffic.remove(name)
        for name, zone in kept.items():
            if name not in self.traffic.zones:
                self.traffic.put(zone)
        for robot in self.roster.members:
            self.traffic.moved(robot)
        self.publish()

    def publish(self) -> None:
        self._publish(ZONES, self.traffic.msg())

    async def _save(self, zones: list[Zone]) -> None:
        """Keep ``zones`` (:class:`NotSaved` when they could not be written)."""
        self.memory.put(SECTION, [z.record() for z in zones])
        await self.memory.durable()

    async def _add(self, request: dict) -> dict:
        async with self._turn:
            return await self._add_now(request)

    async def _add_now(self, request: dict) -> dict:
        try:
            zone = checked_zone(request, self.site_map(), set(self.traffic.zones))
            await self._save([*self.traffic.zones.values(), zone])
        except (Refused, NotSaved) as exc:
            return {"success": False, "message": str(exc)}
        self.traffic.put(zone)
        for robot in self.roster.members:  # a robot standing in it holds it
            self.traffic.moved(robot)
        self.publish()
        crowded = self.traffic.crowded(zone.name)
        return {"success": True, "message": f"zone '{zone.name}' ({zone.kind}) added: one "
                "robot at a time" + (f"; {crowded}" if crowded else "")}

    async def _list(self, _request: dict) -> dict:
        return self.traffic.msg()

    async def _remove(self, request: dict) -> dict:
        async with self._turn:
            return await self._remove_now(request)

    async def _remove_now(self, request: dict) -> dict:
        name = str(request.get("name", ""))
        if name not in self.traffic.zones:
            known = ", ".join(sorted(self.traffic.zones)) or "none"
            return {"success": False, "message": f"name: no zone '{name}' (zones: {known})"}
        try:
            await self._save([z for z in self.traffic.zones.values() if z.name != name])
        except NotSaved as exc:
            return {"success": False, "message": str(exc)}
        self.traffic.remove(name)
        self.publish()
        return {"success": True, "message": f"zone '{name}' removed"}

    async def _release(self, request: dict) -> dict:
        """An operator says the offline robots holding a zone are not in it (carried away,
        switched off elsewhere): they let it go and have no pose until they report one."""
        name = str(request.get("name", ""))
        if name not in self.traffic.zones:
            known = ", ".join(sorted(self.traffic.zones)) or "none"
            return {"success": False, "message": f"name: no zone '{name}' (zones: {known})"}
        offline = {r["name"] for r in self.roster.robots() if r["state"] == OFFLINE}
        gone = sorted(set(self.traffic.holders[name]) & offline)
        if not gone:
            return {"success": False, "message": f"no offline robot holds zone '{name}'"}
        for robot in gone:
            self.roster.unplace(robot)
            self.traffic.let_go(name, robot)
        text = (f"zone '{name}' released by an operator: {', '.join(gone)} (offline) held it "
                "where last seen; if one is still in it, a robot may meet it there")
        log.warning("fleet: %s", text, extra={"ros_node": "/fleet"})
        self.publish()
        return {"success": True, "message": text}

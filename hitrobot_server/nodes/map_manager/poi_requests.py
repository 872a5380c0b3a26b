"""``add_poi``, ``modify_poi``, ``delete_poi`` and the ``get_pois`` service: the points of
interest (:mod:`.pois`) on the bus, the list on the latched ``pois`` topic. A change is
acknowledged as :mod:`..ground.acks` says (once it is on disk); one the state folder could not
take is answered with the reason and taken back."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from ...bus.topics import Message, RequestRejected
from ..base import RobotNode
from ..ground.memory import NotSaved
from ..ground.names import MAP_MANAGER_GET_POIS
from ..ground.placement import placement_problem
from .layers import Grid
from .pois import PoiError, PoiRegistry
from .sections import Sections
from .topics import PKG, POIS_TOPIC, request_topic


class PoiRequests:
    """The POI requests on a registry, remembered in the state folder."""

    def __init__(self, node: RobotNode, pois: PoiRegistry, sections: Sections,
                 grid: Callable[[], Grid | None] = lambda: None):
        self.node, self.pois, self.sections = node, pois, sections
        self.grid = grid  # the composed /map, where a new or moved POI must have room
        self._due = False  # the list is to be kept and published (this turn of the loop)
        node.advertise(POIS_TOPIC, f"{PKG}/PointsOfInterest", latch=True)

    def listen(self) -> None:
        for topic, type_name, handler in (
            ("add_poi", "PointOfInterest", self._on_add_poi),
            ("modify_poi", "ModifyPOI", self._on_modify_poi),
            ("delete_poi", "DeletePointOfInterest", self._on_delete_poi),
        ):
            self.node.subscribe(request_topic(topic), f"{PKG}/{type_name}", handler)

    def serve(self) -> None:
        self.node.service(MAP_MANAGER_GET_POIS, f"{PKG}/GetPointsOfInterest", self._get_pois)

    def publish(self) -> None:
        self.node.publish(POIS_TOPIC, {"pois": self.pois.all()})

    def _changed(self) -> None:
        """Kept and published once per turn of the loop, however many requests it took (a
        burst of adds copied the whole list twice each); before any of their answers waits."""
        if not self._due:
            self._due = True
            asyncio.get_running_loop().call_soon(self._keep)

    def _keep(self) -> None:
        self._due = False
        self.sections.remember("pois")
        self.publish()

    def _placed(self, poi: dict, was: dict | None) -> None:
        """Refuse a POI on an obstacle, an unknown cell, or too near an obstacle (unless it
        stays where it ``was``)."""
        at = poi["pose"]["position"]
        if was is not None and was["pose"]["position"] == at:
            return
        problem = placement_problem(self.grid(), at["x"], at["y"])
        if problem:
            raise PoiError(problem)

    def _request(self, message: Message, what: str, change: Callable[[], str]) -> None:
        try:
            text = change()
        except PoiError as exc:
            raise RequestRejected(f"{what}: {exc}") from None
        self._changed()

        async def acknowledge() -> None:  # once the change is on disk
            try:
                await self.sections.kept(what)
            except NotSaved as exc:
                self.sections.take_back()
                self.publish()
                message.reply.fail(f"{what}: {exc}; the change was taken back")
                return
            message.reply.ok(f"{what}: {text}")

        self.node.spawn(acknowledge())

    def _on_add_poi(self, message: Message) -> None:
        def add() -> str:
            return f"added {self.pois.add(message.msg, self._placed)['name']!r}"

        self._request(message, "add_poi", add)

    def _on_modify_poi(self, message: Message) -> None:
        msg = message.msg

        def modify() -> str:
            new = self.pois.modify(msg["old_name"], msg["poi"], self._placed)
            return f"modified {msg['old_name']!r} (now {new['name']!r})"

        self._request(message, "modify_poi", modify)

    def _on_delete_poi(self, message: Message) -> None:
        name = message.msg["name"]

        def delete() -> str:
            self.pois.delete(name)
            return f"deleted {name!r}"

        self._request(message, "delete_poi", delete)

    async def _get_pois(self, request: dict) -> dict:
        return {"poi_list": {"pois": self.pois.all()}}

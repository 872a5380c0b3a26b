"""Robot namespaces: one named robot's whole interface under ``/NAME/``.

A named robot's nodes are the same nodes a single robot runs; they are handed a
:class:`NamespacedBus` instead of the bus, which moves every name they use (topics, services,
actions, parameters, node names) under ``/NAME/`` — the conventional ROS multi-robot layout —
except the site-wide names in :data:`SITE_WIDE`, which all robots share.
"""

from __future__ import annotations

import asyncio
import re
from collections.abc import Callable, Collection, Hashable, Iterable
from typing import Any

from ..types.registry import TypeRegistry
from .core import Bus
from .demand import ResolvedDemand
from .link import RemoteGraph
from .names import CLIENT_NODE_PREFIX, canonical
from .params import ParamStore
from .services import Action, GoalHandle, Service
from .topics import Message, Origin, Topic

SITE_WIDE = ("/tf", "/tf_static", "/rosout", "/rosapi", "/map_manager", "/fleet")
"""Names (and their subtrees) every robot shares: one TF tree (frames prefixed ``NAME/``),
one log, the site map manager (POIs, masks, saved maps), the fleet."""
SITE_WIDE_TOPICS = frozenset({"/map"})
"""Single names every robot shares: the composed site map (``/map/...`` stays per robot)."""

_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")


def check_robot_name(name: str, reserved: Collection[str] = ()) -> None:
    """Raise ``ValueError`` unless ``name`` can be a robot namespace: a ROS name segment
    (a letter, then letters, digits or ``_``; ≤ 32 characters) that shadows no global name.
    ``reserved``: the first segments of the global names, which the bus does not know (the
    nodes declare theirs; the assembly's ``reserved_names`` collects them for the config)."""
    if not _NAME.fullmatch(name):
        raise ValueError(
            f"robot name {name!r} is invalid: use a letter, then letters, digits or '_' "
            "(at most 32 characters)")
    if name in reserved or name.startswith(CLIENT_NODE_PREFIX[1:]):
        raise ValueError(f"robot name {name!r} would shadow the global name '/{name}'")


class Namespace:
    """Maps a robot node's names into ``/NAME/`` (site-wide names pass unchanged)."""

    def __init__(self, name: str):
        check_robot_name(name)
        self.name = name
        self.prefix = f"/{name}"

    def resolve(self, name: str) -> str:
        name = canonical(name)
        if name == self.prefix or name.startswith(self.prefix + "/"):
            return name
        if name in SITE_WIDE_TOPICS:
            return name
        if any(name == site or name.startswith(site + "/") for site in SITE_WIDE):
            return name
        return self.prefix + name

    def frame(self, frame: str) -> str:
        """A robot's TF frame: ``NAME/base_link`` (tf_prefix style, no leading slash)."""
        return f"{self.name}/{frame.lstrip('/')}"


class NamespacedParams:
    """The parameter store seen from inside a namespace."""

    def __init__(self, store: ParamStore, namespace: Namespace):
        self._store = store
        self._ns = namespace

    def set(self, name: str, value: Any) -> None:
        self._store.set(self._ns.resolve(name), value)

    def get(self, name: str, *default: Any) -> Any:
        return self._store.get(self._ns.resolve(name), *default)

    def has(self, name: str) -> bool:
        return self._store.has(self._ns.resolve(name))

    def delete(self, name: str) -> bool:
        return self._store.delete(self._ns.resolve(name))


class NamespacedBus:
    """The bus as a named robot's nodes see it: every name resolved into the namespace.

    Written out member by member, no forwarding of the rest: a Bus method that takes a name and
    is not here cannot be reached from a robot's nodes, so it cannot escape the namespace
    (``tests/bus/test_namespaced_bus_surface.py`` holds each new one until it is decided).
    The name-free members (types, clock, the tables, the remote graph) are the real bus's.
    """

    def __init__(self, bus: Bus, namespace: Namespace):
        self._bus = bus
        self.namespace = namespace
        self.params = NamespacedParams(bus.params, namespace)

    # ---------------------------------------------------------------- the real bus's
    @property
    def types(self) -> TypeRegistry:
        return self._bus.types

    @property
    def clock(self) -> Callable[[], float]:
        return self._bus.clock

    @property
    def topics(self) -> dict[str, Topic]:
        """Every topic, by absolute name (the other robots' too)."""
        return self._bus.topics

    @property
    def services(self) -> dict[str, Service]:
        return self._bus.services

    @property
    def actions(self) -> dict[str, Action]:
        return self._bus.actions

    @property
    def nodes(self) -> dict[str, int]:
        return self._bus.nodes

    @property
    def log_names(self) -> dict[str, str]:
        """Logger name -> node name (registered already resolved, by :class:`Node`)."""
        return self._bus.log_names

    def remote_graph(self) -> RemoteGraph:
        return self._bus.remote_graph()

    @property
    def watchers(self) -> list[Callable[[str, str], None]]:
        """Told of every change of the whole graph, names absolute (a robot's drive lease
        ends when the client node that held it goes)."""
        return self._bus.watchers

    @property
    def demand(self) -> ResolvedDemand:
        """Who reads a topic, the robot's names resolved (bus/demand.py)."""
        return ResolvedDemand(self._bus.demand, self.namespace.resolve)

    def remove_owner(self, owner: Hashable, keys: Iterable[Hashable] = ()) -> None:
        self._bus.remove_owner(owner, keys)

    # ---------------------------------------------------------------- names resolved
    def node_name(self, name: str) -> str:
        return self.namespace.resolve(name)

    def register_node(self, node: str) -> None:
        self._bus.register_node(self.namespace.resolve(node))

    def unregister_node(self, node: str) -> None:
        self._bus.unregister_node(self.namespace.resolve(node))

    def topic(self, name: str) -> Topic | None:
        return self._bus.topic(self.namespace.resolve(name))

    def advertise(self, name: str, type_name: str | None, owner: Hashable, node: str,
                  latch: bool = False) -> Topic:
        return self._bus.advertise(self.namespace.resolve(name), type_name, owner,
                                   self.namespace.resolve(node), latch=latch)

    def unadvertise(self, name: str, owner: Hashable) -> None:
        self._bus.unadvertise(self.namespace.resolve(name), owner)

    def publish(self, name: str, msg: dict, *args: Any, **kwargs: Any) -> Message:
        return self._bus.publish(self.namespace.resolve(name), msg, *args, **kwargs)

    def subscribe(self, name: str, type_name: str | None, key: Hashable, node: str,
                  *args: Any, **kwargs: Any) -> Topic:
        return self._bus.subscribe(self.namespace.resolve(name), type_name, key,
                                   self.namespace.resolve(node), *args, **kwargs)

    def unsubscribe(self, name: str, key: Hashable) -> None:
        self._bus.unsubscribe(self.namespace.resolve(name), key)

    def advertise_service(self, name: str, type_name: str, owner: Hashable, node: str,
                          *args: Any, **kwargs: Any) -> Service:
        return self._bus.advertise_service(self.namespace.resolve(name), type_name, owner,
                                           self.namespace.resolve(node), *args, **kwargs)

    def unadvertise_service(self, name: str, owner: Hashable) -> bool:
        return self._bus.unadvertise_service(self.namespace.resolve(name), owner)

    def service(self, name: str) -> Service | None:
        return self._bus.service(self.namespace.resolve(name))

    async def call_service(self, name: str, request: dict, timeout: float | None = None,
                           origin: Origin | None = None) -> dict:
        return await self._bus.call_service(self.namespace.resolve(name), request, timeout,
                                            origin)

    def advertise_action(self, name: str, type_name: str, owner: Hashable, node: str,
                         *args: Any, **kwargs: Any) -> Action:
        return self._bus.advertise_action(self.namespace.resolve(name), type_name, owner,
                                          self.namespace.resolve(node), *args, **kwargs)

    def unadvertise_action(self, name: str, owner: Hashable) -> bool:
        return self._bus.unadvertise_action(self.namespace.resolve(name), owner)

    def action(self, name: str) -> Action | None:
        return self._bus.action(self.namespace.resolve(name))

    def start_goal(self, name: str, *args: Any, **kwargs: Any) -> tuple[GoalHandle, asyncio.Task]:
        return self._bus.start_goal(self.namespace.resolve(name), *args, **kwargs)

"""Robot namespaces: one named robot's whole interface under ``/NAME/``.

A named robot's nodes are the same nodes a single robot runs; they are handed a
:class:`NamespacedBus` instead of the bus, which moves every name they use (topics, services,
actions, parameters, node names) under ``/NAME/`` — the conventional ROS multi-robot layout —
except the site-wide names in :data:`SITE_WIDE`, which all robots share.
"""

from __future__ import annotations

import re
from collections.abc import Hashable
from typing import Any

from .core import Bus
from .names import CLIENT_NODE_PREFIX, canonical
from .params import ParamStore

SITE_WIDE = ("/tf", "/tf_static", "/rosout", "/rosapi", "/map_manager", "/fleet")
"""Names (and their subtrees) every robot shares: one TF tree (frames prefixed ``NAME/``),
one log, the site map manager (POIs, masks, saved maps), the fleet."""
SITE_WIDE_TOPICS = frozenset({"/map"})
"""Single names every robot shares: the composed site map (``/map/...`` stays per robot)."""

RESERVED = frozenset({
    # the site-wide names and the server's own nodes
    "tf", "tf_static", "rosout", "rosapi", "map", "map_manager", "fleet", "diagnostics_agg",
    "diagnostic_aggregator", "tf2_web_republisher", "republish_tfs", "hitrobot_server",
    # a single robot's global names: a robot named so would shadow them
    "slamware_ros_sdk_server_node", "scan", "odom", "cmd_vel", "move_base", "move_base_simple",
    "robot_pose", "robot_pose_publisher", "initialpose", "navigation", "planning", "graph",
    "cmd_string", "system_shell", "ros_mode", "robot_state", "robot_id", "Odometry",
    "map_files", "locomotion", "stand_up", "sit_down", "set_listen", "set_map",
    "list_map_files", "load_laser_map", "save_graph_file", "load_graph_file",
    "set_initialpose", "cloud_registered", "merged_points", "downsampled_points",
    "pointcloud_accumulator_node", "compute_path_to_pose", "follow_path",
    "intelligent_navigate_to_pose", "intelligent_navigat_to_pose", "intelligent_navigation",
    "nav", "nav2_actions", "conventional", "shell", "patrol",
    # the recorder's and the player's services and nodes, the demo services
    "record", "recorder", "replay", "add_two_ints", "fibonacci",
})
"""First name segments a robot may not be named: they would shadow a global name."""

_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")


def check_robot_name(name: str) -> None:
    """Raise ``ValueError`` unless ``name`` can be a robot namespace: a ROS name segment
    (a letter, then letters, digits or ``_``; ≤ 32 characters) that shadows no global name."""
    if not _NAME.fullmatch(name):
        raise ValueError(
            f"robot name {name!r} is invalid: use a letter, then letters, digits or '_' "
            "(at most 32 characters)")
    if name in RESERVED or name.startswith(CLIENT_NODE_PREFIX[1:]):
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
    Everything else (types, clock, topic tables, the link) is the real bus's."""

    def __init__(self, bus: Bus, namespace: Namespace):
        self._bus = bus
        self.namespace = namespace
        self.params = NamespacedParams(bus.params, namespace)

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._bus, attr)

    def node_name(self, name: str) -> str:
        return self.namespace.resolve(name)

    def topic(self, name: str):
        return self._bus.topic(self.namespace.resolve(name))

    def advertise(self, name: str, type_name: str | None, owner: Hashable, node: str,
                  latch: bool = False):
        return self._bus.advertise(self.namespace.resolve(name), type_name, owner,
                                   self.namespace.resolve(node), latch=latch)

    def unadvertise(self, name: str, owner: Hashable) -> None:
        self._bus.unadvertise(self.namespace.resolve(name), owner)

    def publish(self, name: str, msg: dict, *args: Any, **kwargs: Any):
        return self._bus.publish(self.namespace.resolve(name), msg, *args, **kwargs)

    def subscribe(self, name: str, type_name: str | None, key: Hashable, node: str,
                  *args: Any, **kwargs: Any):
        return self._bus.subscribe(self.namespace.resolve(name), type_name, key,
                                   self.namespace.resolve(node), *args, **kwargs)

    def unsubscribe(self, name: str, key: Hashable) -> None:
        self._bus.unsubscribe(self.namespace.resolve(name), key)

    def advertise_service(self, name: str, type_name: str, owner: Hashable, node: str,
                          *args: Any, **kwargs: Any):
        return self._bus.advertise_service(self.namespace.resolve(name), type_name, owner,
                                           self.namespace.resolve(node), *args, **kwargs)

    def unadvertise_service(self, name: str, owner: Hashable) -> bool:
        return self._bus.unadvertise_service(self.namespace.resolve(name), owner)

    def service(self, name: str):
        return self._bus.service(self.namespace.resolve(name))

    async def call_service(self, name: str, request: dict, timeout: float | None = None) -> dict:
        return await self._bus.call_service(self.namespace.resolve(name), request, timeout)

    def advertise_action(self, name: str, type_name: str, owner: Hashable, node: str,
                         *args: Any, **kwargs: Any):
        return self._bus.advertise_action(self.namespace.resolve(name), type_name, owner,
                                          self.namespace.resolve(node), *args, **kwargs)

    def unadvertise_action(self, name: str, owner: Hashable) -> bool:
        return self._bus.unadvertise_action(self.namespace.resolve(name), owner)

    def action(self, name: str):
        return self._bus.action(self.namespace.resolve(name))

    def start_goal(self, name: str, *args: Any, **kwargs: Any):
        return self._bus.start_goal(self.namespace.resolve(name), *args, **kwargs)

    def register_node(self, node: str) -> None:
        self._bus.register_node(self.namespace.resolve(node))

    def unregister_node(self, node: str) -> None:
        self._bus.unregister_node(self.namespace.resolve(node))

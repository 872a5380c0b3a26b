"""rosapi: graph, type and parameter introspection services (roslibjs ``Ros.get*``, roslibpy).

Registered once under ``/rosapi/<name>``; the bus canonicalises names, so roslibjs 2.x's
relative ``rosapi/<name>`` reaches the same service.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import orjson

from ..bus.core import Bus
from ..bus.errors import ServiceError
from ..bus.graph import whole_graph
from ..bus.link import PARAM_SERVICES
from ..bus.names import canonical
from ..bus.params import ParamError, check_value_size
from ..types.registry import TypeRegistry, UnknownType
from ..types.typedef import srv_request_typedefs, srv_response_typedefs, typedefs
from .base import Node
from .options import NodeOptions

ACTIONLIB_SUFFIXES = ("goal", "cancel", "status", "feedback", "result")
ROS_PARAMS = {"/rosdistro": "noetic\n", "/rosversion": "1.16.0\n"}
"""What roscore's roslaunch sets (``rosversion -d`` and ``rosversion roslaunch``, each with its
newline): the ROS 1 Noetic this server presents itself as, so a client's distro check finds one."""


def interface_names(types: TypeRegistry) -> list[str]:
    """``ros2 interface list`` of the registry: messages, services and actions, without the
    parts ROS 2 makes of each action (``X_Goal``, ``X_SendGoal``, ...)."""
    return sorted([n for n in types.msg_names() if "/msg/" in n]
                  + [n for n in types.srv_names() if "/srv/" in n] + types.action_names())


class Rosapi(Node):
    """``params=False``: leave the parameter services to the process that keeps the store
    (a secondary worker of ``--workers``; its calls reach worker 0's over the link)."""

    def __init__(self, bus: Bus, settings: NodeOptions, *, params: bool = True):
        super().__init__(bus, "/rosapi")
        self.settings = settings
        handlers: dict[str, tuple[str, Callable[[dict], Awaitable[dict]]]] = {
            "topics": ("rosapi/Topics", self.topics),
            "topics_for_type": ("rosapi/TopicsForType", self.topics_for_type),
            "topics_and_raw_types": ("rosapi/TopicsAndRawTypes", self.topics_and_raw_types),
            "topic_type": ("rosapi/TopicType", self.topic_type),
            "services": ("rosapi/Services", self.services),
            "services_for_type": ("rosapi/ServicesForType", self.services_for_type),
            "service_type": ("rosapi/ServiceType", self.service_type),
            "service_providers": ("rosapi/ServiceProviders", self.service_providers),
            "service_node": ("rosapi/ServiceNode", self.service_node),
            "service_host": ("rosapi/ServiceHost", self.service_host),
            "nodes": ("rosapi/Nodes", self.nodes),
            "node_details": ("rosapi/NodeDetails", self.node_details),
            "publishers": ("rosapi/Publishers", self.publishers),
            "subscribers": ("rosapi/Subscribers", self.subscribers),
            "action_servers": ("rosapi/GetActionServers", self.action_servers),
            "get_param": ("rosapi/GetParam", self.get_param),
            "set_param": ("rosapi/SetParam", self.set_param),
            "has_param": ("rosapi/HasParam", self.has_param),
            "delete_param": ("rosapi/DeleteParam", self.delete_param),
            "search_param": ("rosapi/SearchParam", self.search_param),
            "get_param_names": ("rosapi/GetParamNames", self.get_param_names),
            "message_details": ("rosapi/MessageDetails", self.message_details),
            "service_request_details": ("rosapi/ServiceRequestDetails", self.request_details),
            "service_response_details": ("rosapi/ServiceResponseDetails", self.response_details),
            "get_time": ("rosapi/GetTime", self.get_time),
            # rosbridge 2.x's rosapi (ROS 2): the interfaces, the action parts, the version
            "interfaces": ("rosapi/Interfaces", self.interfaces),
            "action_goal_details": ("rosapi/ActionGoalDetails", self.action_details("goal")),
            "action_result_details": ("rosapi/ActionResultDetails",
                                      self.action_details("result")),
            "action_feedback_details": ("rosapi/ActionFeedbackDetails",
                                        self.action_details("feedback")),
            "get_ros_version": ("rosapi/GetROSVersion", self.get_ros_version),
        }
        if params:  # the process that keeps the store seeds what every roscore sets
            for name, value in ROS_PARAMS.items():
                if not bus.params.has(name):
                    bus.params.set(name, value)
        for name, (type_name, handler) in handlers.items():
            if not params and f"/rosapi/{name}" in PARAM_SERVICES:
                continue
            self.service(f"/rosapi/{name}", type_name, handler)

    # ------------------------------------------------------------------ helpers
    def _short(self, name: str) -> str:
        return self.bus.types.short(name)

    def _topics(self) -> list[tuple[str, str]]:
        """(name, type) of every topic here and in processes joined by a link."""
        allow = self.settings.topics_filter.allows
        found = whole_graph(self.bus).topics
        return sorted((n, t) for n, t in found.items() if allow(n))

    def _services(self) -> list[tuple[str, str]]:
        allow = self.settings.services_filter.allows
        found = whole_graph(self.bus).services
        return sorted((n, t) for n, (t, _node) in found.items() if allow(n))

    def _same_type(self, a: str, b: str, kind: str) -> bool:
        lookup = getattr(self.bus.types, kind)
        try:
            return lookup(a).name == lookup(b).name
        except UnknownType:
            return False

    # ------------------------------------------------------------------ topics
    async def topics(self, req: dict) -> dict:
        ts = self._topics()
        return {"topics": [n for n, _t in ts], "types": [self._short(t) for _n, t in ts]}

    async def topics_for_type(self, req: dict) -> dict:
        return {
            "topics": [n for n, t in self._topics() if self._same_type(t, req["type"], "msg")]
        }

    def _definition(self, type_name: str) -> str:
        try:
            return self.bus.types.definition_text(type_name)
        except UnknownType:
            return ""  # a ROS 2 type from another process that this registry lacks

    async def topics_and_raw_types(self, req: dict) -> dict:
        ts = self._topics()
        return {
            "topics": [n for n, _t in ts],
            "types": [self._short(t) for _n, t in ts],
            "typedefs_full_text": [self._definition(t) for _n, t in ts],
        }

    async def topic_type(self, req: dict) -> dict:
        name = canonical(req["topic"]) if req["topic"] else ""
        found = dict(self._topics())
        return {"type": self._short(found[name]) if name in found else ""}

    async def publishers(self, req: dict) -> dict:
        name = canonical(req["topic"]) if req["topic"] else ""
        return {"publishers": sorted(whole_graph(self.bus).publishers.get(name, ()))}

    async def subscribers(self, req: dict) -> dict:
        name = canonical(req["topic"]) if req["topic"] else ""
        return {"subscribers": sorted(whole_graph(self.bus).subscribers.get(name, ()))}

    # ------------------------------------------------------------------ services
    async def services(self, req: dict) -> dict:
        return {"services": [n for n, _t in self._services()]}

    async def services_for_type(self, req: dict) -> dict:
        return {
            "services": [n for n, t in self._services() if self._same_type(t, req["type"], "srv")]
        }

    async def service_type(self, req: dict) -> dict:
        svc = self.bus.service(req["service"]) if req["service"] else None
        return {"type": self._short(svc.type_name) if svc else ""}

    async def service_providers(self, req: dict) -> dict:
        svc = self.bus.service(req["service"]) if req["service"] else None
        return {"providers": [svc.node] if svc else []}

    async def service_node(self, req: dict) -> dict:
        svc = self.bus.service(req["service"]) if req["service"] else None
        return {"node": svc.node if svc else ""}

    async def service_host(self, req: dict) -> dict:
        svc = self.bus.service(req["service"]) if req["service"] else None
        return {"host": "localhost" if svc else ""}

    # ------------------------------------------------------------------ graph
    async def nodes(self, req: dict) -> dict:
        return {"nodes": sorted(whole_graph(self.bus).nodes)}

    async def node_details(self, req: dict) -> dict:
        node = canonical(req["node"]) if req["node"] else ""
        ts = self.bus.topics.values()
        return {
            "subscribing": sorted(
                t.name for t in ts if any(n == node for n, _cb in t.subscribers.values())
            ),
            "publishing": sorted(t.name for t in ts if node in t.publishers.values()),
            "services": sorted(s.name for s in self.bus.services.values() if s.node == node),
        }

    async def action_servers(self, req: dict) -> dict:
        """ROS 1 actionlib namespaces (all five topics present) plus ROS 2 actions."""
        names = {t.name for t in self.bus.topics.values()}
        spaces = {n.rsplit("/", 1)[0] for n in names if n.endswith("/goal")}
        found = {ns for ns in spaces if all(f"{ns}/{s}" in names for s in ACTIONLIB_SUFFIXES)}
        found.update(whole_graph(self.bus).actions)
        return {"action_servers": sorted(found)}

    # ------------------------------------------------------------------ types
    def _typedefs(self, fn, name: str) -> dict:
        try:
            return {"typedefs": fn(self.bus.types, name)}
        except UnknownType as exc:
            raise ServiceError(str(exc.args[0] if exc.args else exc)) from None

    async def message_details(self, req: dict) -> dict:
        return self._typedefs(typedefs, req["type"])

    def action_details(self, part: str) -> Callable[[dict], Awaitable[dict]]:
        """``action_<part>_details``: the typedefs of an action's goal, result or feedback."""
        async def details(req: dict) -> dict:
            try:
                name = getattr(self.bus.types.action(req["type"]), part).name
            except UnknownType as exc:
                raise ServiceError(str(exc.args[0] if exc.args else exc)) from None
            return self._typedefs(typedefs, name)
        return details

    async def interfaces(self, req: dict) -> dict:
        return {"interfaces": interface_names(self.bus.types)}

    async def get_ros_version(self, req: dict) -> dict:
        """ROS 1 Noetic, as ``/rosdistro`` says (a ROS 1 master speaking ROS 2 ops too)."""
        return {"version": 1, "distro": ROS_PARAMS["/rosdistro"].strip()}

    async def request_details(self, req: dict) -> dict:
        return self._typedefs(srv_request_typedefs, req["type"])

    async def response_details(self, req: dict) -> dict:
        return self._typedefs(srv_response_typedefs, req["type"])

    # ------------------------------------------------------------------ params
    def _param_name(self, name: str) -> str:
        name = canonical(name)
        if not self.settings.params_filter.allows(name):
            raise ServiceError(f"parameter '{name}' is not allowed by --params-glob")
        return name

    @staticmethod
    def _parse(name: str, text: str, what: str):
        """A parameter value's JSON text, its size checked before it is parsed."""
        try:
            check_value_size(name, len(text))
            return orjson.loads(text)
        except orjson.JSONDecodeError as exc:
            raise ServiceError(f"{what} must be JSON text (e.g. '42' or '\"a\"'): {exc}") from None
        except ParamError as exc:
            raise ServiceError(f"{what}: {exc}") from None

    async def get_param(self, req: dict) -> dict:
        name = self._param_name(req["name"])
        default = self._parse(name, req["default"], "default") if req.get("default") else None
        return {"value": self.bus.params.get_json(name, default).decode()}

    async def set_param(self, req: dict) -> dict:
        name = self._param_name(req["name"])
        try:
            self.bus.params.set_json(name, req["value"])
        except orjson.JSONDecodeError as exc:
            raise ServiceError(f"value must be JSON text (e.g. '42' or '\"a\"'): {exc}") from None
        except ValueError as exc:
            raise ServiceError(str(exc)) from None
        return {}

    async def has_param(self, req: dict) -> dict:
        return {"exists": self.bus.params.has(self._param_name(req["name"]))}

    async def delete_param(self, req: dict) -> dict:
        name = self._param_name(req["name"])
        if not self.bus.params.delete(name):
            raise ServiceError(f"parameter '{name}' is not set")
        return {}

    async def search_param(self, req: dict) -> dict:
        return {"global_name": self.bus.params.search(req["name"])}

    async def get_param_names(self, req: dict) -> dict:
        allow = self.settings.params_filter.allows
        return {"names": [n for n in self.bus.params.names() if allow(n)]}

    async def get_time(self, req: dict) -> dict:
        now = self.bus.clock()
        secs = int(now)
        return {"time": {"secs": secs, "nsecs": int((now - secs) * 1e9)}}

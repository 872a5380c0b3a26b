"""NamespacedBus is written out: every public Bus member that takes a name is mapped through the
robot's namespace, or listed below with the reason it is not — so a new Bus method cannot
escape the namespace silently; it fails here until someone decides."""

from __future__ import annotations

import inspect
import re

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.namespace import Namespace, NamespacedBus
from hitrobot_server.types.registry import TypeRegistry

# A parameter that carries a graph name (a topic, service, action or node).
NAME_PARAM = re.compile(r"(name|topic|service|action|node)s?|(topic|service|action|node)_names?")

# Public Bus members a robot's view does not offer, each with its reason.
NOT_ON_THE_VIEW: dict[str, str] = {
    # takes a name, but only a client's session calls it: a client never holds a robot's view
    "client_called": "the taps' record of a client's call (sessions only)",
    # takes a name, but only the link calls it: the link holds the whole bus
    "remote_changed": "the link's news of another process's entity",
    # name-free, and none of a node's business
    "link": "the server joins the bus to other processes, before any robot starts",
    "remote_watchers": "the Foxglove sessions follow the whole graph (bus/graph.py GraphView)",
    "taps": "the recorder observes the whole bus",
    "unregister_timeout": "the server's setting for unused topics",
}


def public_members(bus_class: type[Bus] = Bus) -> dict[str, object]:
    """The bus's public methods and instance attributes."""
    members: dict[str, object] = {
        name: member for name, member in inspect.getmembers(bus_class, inspect.isfunction)
        if not name.startswith("_")
    }
    members.update((name, value) for name, value in vars(bus_class(TypeRegistry.default())).items()
                   if not name.startswith("_"))
    return members


def unmapped(bus_class: type[Bus] = Bus) -> list[str]:
    """The bus's methods that take a name and that the view neither maps nor lists."""
    return [
        name for name, member in public_members(bus_class).items()
        if inspect.isfunction(member) and name_params(member)
        and name not in vars(NamespacedBus) and name not in NOT_ON_THE_VIEW
    ]


def name_params(fn: object) -> list[str]:
    return [p for p in inspect.signature(fn).parameters if NAME_PARAM.fullmatch(p)]


def test_the_view_forwards_nothing_implicitly():
    assert "__getattr__" not in vars(NamespacedBus)
    assert "__getattribute__" not in vars(NamespacedBus)


def test_every_bus_method_taking_a_name_is_written_out_or_listed():
    missing = unmapped()
    assert not missing, (f"Bus methods taking a name that NamespacedBus neither maps nor lists "
                         f"in NOT_ON_THE_VIEW: {missing}")


def test_the_rule_catches_a_new_method_taking_a_name():
    class Grown(Bus):
        def forget(self, topic: str) -> None: ...

        def rename_node(self, node_name: str, to: str) -> None: ...

        def counts(self, limit: int) -> int: ...

    assert unmapped(Grown) == ["forget", "rename_node"]


def test_every_public_bus_member_is_on_the_view_or_listed():
    view = NamespacedBus(Bus(TypeRegistry.default()), Namespace("gamma"))
    missing = [name for name in public_members()
               if name not in NOT_ON_THE_VIEW and not hasattr(view, name)]
    assert not missing, f"Bus members NamespacedBus neither offers nor lists: {missing}"


def test_the_list_names_only_bus_members_the_view_lacks():
    members = public_members()
    assert set(NOT_ON_THE_VIEW) <= set(members)
    assert not [name for name in NOT_ON_THE_VIEW if name in vars(NamespacedBus)]


class _Recorder:
    """Stands in for the bus: each method records the arguments it was called with."""

    def __init__(self) -> None:
        self.params = Bus(TypeRegistry.default()).params
        self.calls: dict[str, inspect.BoundArguments] = {}

    def __getattr__(self, attr: str):
        signature = inspect.signature(getattr(Bus, attr))

        def record(*args, **kwargs):
            self.calls[attr] = signature.bind(None, *args, **kwargs)
            return {}

        async def record_async(*args, **kwargs):
            return record(*args, **kwargs)

        return record_async if inspect.iscoroutinefunction(getattr(Bus, attr)) else record


async def test_each_written_out_method_maps_every_name_into_the_namespace():
    checked = 0
    for name, member in public_members().items():
        if not (inspect.isfunction(member) and name_params(member)) or name in NOT_ON_THE_VIEW:
            continue
        if name == "node_name":  # answers itself: the resolved name
            assert NamespacedBus(Bus(TypeRegistry.default()), Namespace("gamma")).node_name(
                "x") == "/gamma/x"
            continue
        bus = _Recorder()
        view = NamespacedBus(bus, Namespace("gamma"))  # type: ignore[arg-type]
        params = list(inspect.signature(member).parameters.values())[1:]
        args = {p.name: "x" if NAME_PARAM.fullmatch(p.name) else object() for p in params
                if p.default is inspect.Parameter.empty}
        result = getattr(view, name)(**args)
        if inspect.iscoroutine(result):
            await result
        got = bus.calls[name].arguments
        for param, value in args.items():
            expected = "/gamma/x" if NAME_PARAM.fullmatch(param) else value
            assert got[param] is expected or got[param] == expected, (name, param, got[param])
        checked += 1
    assert checked >= 15

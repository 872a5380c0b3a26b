"""The node hooks are declared on Node (no-op defaults) and called directly: a plain Node
starts, adopts, reports and stops like any other, and the assembly and the state binder find
no hook by name."""

from __future__ import annotations

import ast
import inspect

from hitrobot_server import robot_state
from hitrobot_server.bus.core import Bus
from hitrobot_server.nodes import assembly
from hitrobot_server.nodes.base import Node
from hitrobot_server.types.registry import TypeRegistry


async def test_a_plain_node_has_every_hook():
    bus = Bus(TypeRegistry.default())
    node = Node(bus, "/plain")
    await assembly._start([node])
    node.adopt(True)
    assert assembly.restored_summary([node]) == []
    await assembly.stop_nodes([node])
    assert "/plain" not in bus.nodes


def test_no_hook_is_looked_up_by_name():
    for module in (assembly, robot_state):
        calls = [n.func.id for n in ast.walk(ast.parse(inspect.getsource(module)))
                 if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)]
        assert not {"getattr", "hasattr"} & set(calls), module.__name__


def test_every_module_of_a_node_package_names_the_node_on_rosout():
    """/rosout names a record's node by the longest registered prefix of its logger: the
    package of a node split into modules (map_manager/), the module of a one-module node."""
    bus = Bus(TypeRegistry.default())

    class Packaged(Node):
        pass

    class Single(Node):
        pass

    Packaged.__module__ = "hitrobot_server.nodes.map_manager.node"
    Single.__module__ = "hitrobot_server.nodes.fleet"
    Packaged(bus, "/map_manager")
    Single(bus, "/fleet")
    assert bus.log_names["hitrobot_server.nodes.map_manager"] == "/map_manager"
    assert bus.log_names["hitrobot_server.nodes.fleet"] == "/fleet"

"""A node's parameters as ROS 2 clients read them: the ``rcl_interfaces`` services.

The store is ROS 1's tree (``/node/a/b``); ROS 2 names a node's parameter relative to it with
dots (``a.b``). Each node that owns parameters (a namespace of the tree named like the node)
serves ``<node>/list_parameters``, ``get_parameters``, ``set_parameters`` and
``describe_parameters`` over the same store, so a value set either way reads back both ways.
A JSON value ROS 2 has no type for (null, a list of mixed or nested items) reads as a string
holding its JSON text.
"""

from __future__ import annotations

import base64
import re
from collections.abc import Callable
from typing import Any

import orjson

from ...bus.errors import ServiceError
from ..base import Node

PKG = "rcl_interfaces/srv"
NOT_SET, BOOL, INTEGER, DOUBLE, STRING = 0, 1, 2, 3, 4
BYTE_ARRAY, BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY = 5, 6, 7, 8, 9
_FIELDS = {BOOL: "bool_value", INTEGER: "integer_value", DOUBLE: "double_value",
           STRING: "string_value", BYTE_ARRAY: "byte_array_value",
           BOOL_ARRAY: "bool_array_value", INTEGER_ARRAY: "integer_array_value",
           DOUBLE_ARRAY: "double_array_value", STRING_ARRAY: "string_array_value"}
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


def type_of(value: Any) -> int:
    """The ParameterType of a JSON value (STRING for one ROS 2 cannot type: its JSON text)."""
    for kind, scalar in ((BOOL, bool), (INTEGER, int), (DOUBLE, float), (STRING, str)):
        if type(value) is scalar:
            return kind
    if isinstance(value, list):
        for kind, scalar in ((BOOL_ARRAY, bool), (INTEGER_ARRAY, int), (STRING_ARRAY, str)):
            if value and all(type(v) is scalar for v in value):
                return kind
        if value and all(type(v) in (int, float) for v in value):
            return DOUBLE_ARRAY
        if not value:
            return STRING_ARRAY
    return STRING


def value_of(value: Any) -> dict:
    """A JSON value as an ``rcl_interfaces/ParameterValue``."""
    kind = type_of(value)
    if kind == STRING and not isinstance(value, str):
        value = orjson.dumps(value).decode()
    elif kind == DOUBLE_ARRAY:
        value = [float(v) for v in value]
    return {"type": kind, _FIELDS[kind]: value}


def json_of(value: dict) -> Any:
    """An ``rcl_interfaces/ParameterValue`` as a JSON value (None: not set)."""
    kind = value.get("type", NOT_SET)
    if kind == NOT_SET:
        return None
    if kind not in _FIELDS:
        raise ValueError(f"parameter type {kind} is not a ParameterType")
    out = value.get(_FIELDS[kind])
    if kind == BYTE_ARRAY and isinstance(out, str):  # rosbridge sends uint8[] as base64
        out = list(base64.b64decode(out))
    elif isinstance(out, (bytes, bytearray)):
        out = list(out)
    return list(out) if kind >= BYTE_ARRAY else out


def flatten(tree: Any, prefix: str = "") -> dict[str, Any]:
    """A node's subtree as ROS 2 names (``a.b``) → values; no recursion limit met (the
    store's depth is bounded), done with a stack."""
    out: dict[str, Any] = {}
    stack = [(tree, prefix)]
    while stack:
        node, at = stack.pop()
        if isinstance(node, dict) and (node or not at):
            stack.extend((child, f"{at}.{key}" if at else key) for key, child in node.items())
        elif at:
            out[at] = node
    return out


def listed(names: list[str], prefixes: list[str], depth: int) -> dict:
    """``list_parameters``' answer as rclcpp builds it: a name under no prefix counts when
    none is asked and its depth fits; the prefixes are the names' own, each once."""
    found: list[str] = []
    found_prefixes: list[str] = []

    def fits(rest: str) -> bool:
        return depth == 0 or rest.count(".") < depth

    for name in sorted(names):
        under = any(name == p or (name.startswith(p + ".") and fits(name[len(p) + 1:]))
                    for p in prefixes)
        if (not prefixes and fits(name)) or under:
            found.append(name)
            if "." in name and name.rsplit(".", 1)[0] not in found_prefixes:
                found_prefixes.append(name.rsplit(".", 1)[0])
    return {"result": {"names": found, "prefixes": found_prefixes}}


class ParameterServices:
    """The four services of ``node``'s parameters; ``allows`` is ``--params-glob`` over the
    store's names (a name it refuses is neither read nor written, as rosapi does)."""

    def __init__(self, node: Node, allows: Callable[[str], bool]):
        self.node, self.allows = node, allows
        self.params = node.bus.params
        for name, handler in (("list_parameters", self.list_parameters),
                              ("get_parameters", self.get_parameters),
                              ("set_parameters", self.set_parameters),
                              ("describe_parameters", self.describe_parameters)):
            type_name = "".join(p.capitalize() for p in name.split("_"))
            node.service(f"{node.name}/{name}", f"{PKG}/{type_name}", handler)

    def _path(self, name: str) -> str:
        if not _NAME.match(name):
            raise ServiceError(f"parameter name {name!r} is not a ROS 2 name (a.b_c)")
        return f"{self.node.name}/{name.replace('.', '/')}"

    def _owned(self) -> dict[str, Any]:
        tree = self.params.get(self.node.name, {})
        return {n: v for n, v in flatten(tree).items() if self.allows(self._path(n))}

    def _read(self, name: str) -> tuple[bool, Any]:
        path = self._path(name)
        if not self.allows(path) or not self.params.has(path):
            return False, None
        value = self.params.get(path)
        return not isinstance(value, dict), value

    async def list_parameters(self, req: dict) -> dict:
        return listed(list(self._owned()), list(req.get("prefixes") or []),
                      int(req.get("depth") or 0))

    async def get_parameters(self, req: dict) -> dict:
        values = []
        for name in req.get("names") or []:
            found, value = self._read(name)
            values.append(value_of(value) if found else {"type": NOT_SET})
        return {"values": values}

    async def describe_parameters(self, req: dict) -> dict:
        out = []
        for name in req.get("names") or []:
            found, value = self._read(name)
            out.append({"name": name, "type": type_of(value) if found else NOT_SET,
                        "dynamic_typing": True})
        return {"descriptors": out}

    async def set_parameters(self, req: dict) -> dict:
        """Each parameter set on its own (ROS 2's non-atomic service); NOT_SET deletes it."""
        return {"results": [self._set_one(p) for p in req.get("parameters") or []]}

    def _set_one(self, parameter: dict) -> dict:
        name = parameter.get("name", "")
        try:
            path = self._path(name)
            if not self.allows(path):
                raise ValueError(f"parameter '{path}' is not allowed by --params-glob")
            value = json_of(parameter.get("value") or {})
            if value is None:
                self.params.delete(path)
            else:
                self.params.set(path, value)
        except (ServiceError, ValueError) as exc:  # ParamError is a ValueError
            return {"successful": False, "reason": str(exc)}
        return {"successful": True, "reason": ""}


def serve_parameters(nodes: list[Node], allows: Callable[[str], bool]) -> None:
    """Give every node of ``nodes`` that owns parameters its ``rcl_interfaces`` services."""
    for node in nodes:
        if isinstance(node.bus.params.get(node.name, None), dict):
            ParameterServices(node, allows)

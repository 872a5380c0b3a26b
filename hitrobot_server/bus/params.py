"""A ROS-1-style parameter server: a tree of values addressed by slash-separated names.

Every value is checked like a message before it goes in (its JSON size, its nesting depth
counted from the root, so that ``get('/')`` of the whole tree always encodes) and copied through
orjson, in C: nothing here recurses in Python, so no value can exhaust the stack or hold the
event loop the way ``copy.deepcopy`` of a million-element list did.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import orjson

from .names import canonical

_MISSING = object()

MAX_VALUE_BYTES = 1_000_000
"""Largest value one ``set`` stores, as JSON text (a 1 MB value parses in about 20 ms)."""
MAX_TOTAL_BYTES = 16 * MAX_VALUE_BYTES
"""The whole tree's JSON, summed over the values set (what ``get('/')`` sends at most)."""
MAX_DEPTH = 100
"""Deepest nesting of the tree: a value's own depth plus the segments of its name. orjson
refuses to encode beyond 255 levels, so a deeper value would break ``get('/')`` for everyone."""


class ParamError(ValueError):
    """A value the store refuses; the store is left unchanged."""


_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"')
_OPEN = np.zeros(256, np.int8)
_OPEN[[ord("["), ord("{")]] = 1
_OPEN[[ord("]"), ord("}")]] = -1


def json_depth(data: bytes) -> int:
    """Nesting depth of a JSON text (0 for a scalar): its strings blanked by a regex, then the
    running count of brackets taken by numpy; no Python loop over the elements."""
    skeleton = _STRING.sub(b'""', data)
    steps = _OPEN[np.frombuffer(skeleton, np.uint8)]
    return int(np.cumsum(steps, dtype=np.int32).max(initial=0))


def _leaves(node: Any, prefix: tuple[str, ...]) -> list[tuple[str, ...]]:
    """The names (as parts) of every leaf under ``node`` (itself when it is not a dict)."""
    out: list[tuple[str, ...]] = []
    stack = [(node, prefix)]
    while stack:
        value, parts = stack.pop()
        if isinstance(value, dict) and value:
            stack.extend((item, (*parts, key)) for key, item in value.items())
        else:
            out.append(parts)
    return out


class ParamStore:
    """Nested dict keyed by name segments, so ``get('/a')`` returns the subtree like rosparam."""

    def __init__(self) -> None:
        self._root: dict[str, Any] = {}
        self._sizes: dict[tuple[str, ...], int] = {}  # JSON bytes of each value set, by name
        self.total_bytes = 0

    @staticmethod
    def _parts(name: str) -> list[str]:
        return [p for p in canonical(name).split("/") if p]

    def set(self, name: str, value: Any) -> None:
        """Store a copy of ``value``; raises :class:`ParamError` (changing nothing) when it is
        too big, too deep, or not JSON."""
        try:
            data = orjson.dumps(value)
        except TypeError as exc:
            raise ParamError(f"parameter '{canonical(name)}' is not a JSON value: {exc}") from None
        self.set_json(name, data)

    def set_json(self, name: str, data: bytes | str) -> None:
        """Store the value of a JSON text, checked (size before parsing, depth, total) first;
        raises :class:`ParamError`, or ``orjson.JSONDecodeError`` for text that is not JSON."""
        parts = self._parts(name)
        check_value_size(name, len(data))
        if isinstance(data, str):
            try:
                data = data.encode()
            except UnicodeEncodeError:
                raise ParamError(f"parameter '{canonical(name)}' is not valid Unicode") from None
            check_value_size(name, len(data))
        value = orjson.loads(data)
        if not parts and not isinstance(value, dict):
            raise ParamError("the root parameter '/' can only be set to a dictionary")
        depth = len(parts) + json_depth(data)
        if depth > MAX_DEPTH:
            raise ParamError(
                f"parameter '{canonical(name)}' is nested {depth} levels deep counting its "
                f"name, more than the limit of {MAX_DEPTH}")
        freed = self._replaced(parts)
        total = self.total_bytes - sum(self._sizes.get(key, 0) for key in freed) + len(data)
        if total > MAX_TOTAL_BYTES:
            raise ParamError(
                f"parameter '{canonical(name)}' was refused: the parameter server would hold "
                f"{total} bytes, more than the limit of {MAX_TOTAL_BYTES}")
        for key in freed:
            self._sizes.pop(key, None)
        if not parts:
            self._root = value
        else:
            node = self._root
            for p in parts[:-1]:
                child = node.get(p)
                if not isinstance(child, dict):
                    child = node[p] = {}
                node = child
            node[parts[-1]] = value
        self._sizes[tuple(parts)] = len(data)
        self.total_bytes = total

    def _replaced(self, parts: list[str]) -> list[tuple[str, ...]]:
        """The names whose sizes stop counting when ``parts`` is set: the old value there (and
        what was set under it), and a non-dict value on the way that becomes a namespace."""
        gone: list[tuple[str, ...]] = []
        node: Any = self._root
        for i, p in enumerate(parts):
            if not isinstance(node, dict):
                gone.append(tuple(parts[:i]))
                return gone
            if p not in node:
                return gone
            node = node[p]
        gone.extend(_subtree_keys(self._sizes, node, tuple(parts)))
        return gone

    def _node(self, name: str) -> Any:
        node: Any = self._root
        for p in self._parts(name):
            if not isinstance(node, dict) or p not in node:
                return _MISSING
            node = node[p]
        return node

    def get(self, name: str, default: Any = _MISSING) -> Any:
        node = self._node(name)
        if node is _MISSING:
            if default is _MISSING:
                raise KeyError(name)
            return default
        return orjson.loads(orjson.dumps(node))

    def get_json(self, name: str, default: Any = None) -> bytes:
        """The value (or ``default``) as JSON text, without copying it first."""
        node = self._node(name)
        return orjson.dumps(default if node is _MISSING else node)

    def has(self, name: str) -> bool:
        return self._node(name) is not _MISSING

    def delete(self, name: str) -> bool:
        parts = self._parts(name)
        if not parts:
            self._root = {}
            self._sizes.clear()
            self.total_bytes = 0
            return True
        node: Any = self._root
        for p in parts[:-1]:
            if not isinstance(node, dict) or p not in node:
                return False
            node = node[p]
        if isinstance(node, dict) and parts[-1] in node:
            for key in self._replaced(parts):
                self.total_bytes -= self._sizes.pop(key, 0)
            del node[parts[-1]]
            return True
        return False

    def names(self) -> list[str]:
        """Every leaf name, as rosapi's get_param_names lists them."""
        return sorted("/" + "/".join(parts) for parts in _leaves(self._root, ()) if parts)

    def search(self, key: str, namespace: str = "/") -> str:
        """Closest ``key`` up the namespace chain (rosparam search semantics), or ''."""
        key = key.strip("/")
        ns = self._parts(namespace)
        first = key.split("/")[0]
        for i in range(len(ns), -1, -1):
            base = "/" + "/".join(ns[:i] + [first]) if ns[:i] else "/" + first
            if self.has(base):
                return canonical(base + key[len(first) :])
        return ""


def check_value_size(name: str, size: int) -> None:
    """Refuse a value of more than :data:`MAX_VALUE_BYTES` (before parsing it, where known)."""
    if size > MAX_VALUE_BYTES:
        raise ParamError(
            f"parameter '{canonical(name)}' is {size} bytes of JSON, more than the limit of "
            f"{MAX_VALUE_BYTES}")


def _subtree_keys(sizes: dict[tuple[str, ...], int], node: Any,
                  prefix: tuple[str, ...]) -> list[tuple[str, ...]]:
    """The sized names at or under ``prefix``: walks the tree below it (every name that was set
    there is a node of it), so the cost follows what is replaced, not the whole store."""
    found = [prefix] if prefix in sizes else []
    stack = [(node, prefix)]
    while stack:
        value, parts = stack.pop()
        if isinstance(value, dict):
            for key, item in value.items():
                child = (*parts, key)
                if child in sizes:
                    found.append(child)
                stack.append((item, child))
    return found

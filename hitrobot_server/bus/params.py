"""A ROS-1-style parameter server: a tree of values addressed by slash-separated names.

Every value is checked like a message before it goes in (its JSON size, its nesting depth
counted from the root, so that ``get('/')`` of the whole tree always encodes). Values are kept as
JSON text, one per leaf of the name tree, never as Python objects: a 1 MB ``[[],[],…]`` is one
bytes object, not 333,000 lists that every later garbage collection would walk, and reading
it back copies bytes. Nothing here recurses in Python, so no value can exhaust the stack.
"""

from __future__ import annotations

import gc
import logging
import re
from collections.abc import Callable
from typing import Any

import numpy as np
import orjson

from .names import canonical

log = logging.getLogger(__name__)

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


_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"')
"""A JSON string, its plain runs matched as runs (one alternation per character took 1.5 s for
a 1 MB string: a client's setParameters held the loop and the memory of its texts meanwhile)."""
_OPEN = np.zeros(256, np.int8)
_OPEN[[ord("["), ord("{")]] = 1
_OPEN[[ord("]"), ord("}")]] = -1


def json_depth(data: bytes) -> int:
    """Nesting depth of a JSON text (0 for a scalar): its strings blanked by a regex, then the
    running count of brackets taken by numpy; no Python loop over the elements."""
    skeleton = _STRING.sub(b'""', data)
    steps = _OPEN[np.frombuffer(skeleton, np.uint8)]
    return int(np.cumsum(steps, dtype=np.int32).max(initial=0))


Node = dict[str, Any] | bytes  # a namespace (names → nodes), or a value as JSON text


class ParamStore:
    """A tree of names, so ``get('/a')`` returns the subtree like rosparam; a dictionary value
    becomes names too (``set('/a', {"b": 1})`` then ``get('/a/b')`` is 1)."""

    def __init__(self) -> None:
        self._root: dict[str, Node] = {}
        self.total_bytes = 0  # JSON text of every value and the length of every name held
        # Called with the name after every set/delete (Foxglove parameter subscriptions).
        self.watchers: list[Callable[[str], None]] = []

    def _notify(self, name: str) -> None:
        for watcher in list(self.watchers):
            try:
                watcher(canonical(name))
            except Exception:  # a watcher's bug must not fail the set that was made
                log.exception("parameter watcher %r failed", watcher)

    @staticmethod
    def _parts(name: str) -> list[str]:
        return [p for p in canonical(name).split("/") if p]

    def set(self, name: str, value: Any) -> None:
        """Store ``value``; raises :class:`ParamError` (changing nothing) when it is too big,
        too deep, or not JSON."""
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
        value = _parse(data)  # validates; only a dictionary's items are kept apart
        if not parts and not isinstance(value, dict):
            raise ParamError("the root parameter '/' can only be set to a dictionary")
        depth = len(parts) + json_depth(data)
        if depth > MAX_DEPTH:
            raise ParamError(
                f"parameter '{canonical(name)}' is nested {depth} levels deep counting its "
                f"name, more than the limit of {MAX_DEPTH}")
        node = _as_node(value, data)
        del value
        total = self.total_bytes + self._growth(parts, node)
        if total > MAX_TOTAL_BYTES:
            raise ParamError(
                f"parameter '{canonical(name)}' was refused: the parameter server would hold "
                f"{total} bytes, more than the limit of {MAX_TOTAL_BYTES}")
        if not parts:
            assert isinstance(node, dict)
            self._root = node
        else:
            parent = self._root
            for p in parts[:-1]:
                child = parent.get(p)
                if not isinstance(child, dict):
                    child = parent[p] = {}
                parent = child
            parent[parts[-1]] = node
        self.total_bytes = total
        self._notify(name)

    def update(self, changes: list[tuple[str, Any]]) -> None:
        """Set every name (deleting those whose value is None), or none: all are applied to
        a copy of the tree (its texts shared, not copied), which replaces the tree only once
        every one went in; the first refusal raises :class:`ParamError` with the store
        unchanged. Watchers hear of the names once all are in."""
        trial = ParamStore()
        trial._root = _copy_tree(self._root)
        trial.total_bytes = self.total_bytes
        for name, value in changes:
            if value is None:
                trial.delete(name)
            else:
                trial.set(name, value)
        self._root, self.total_bytes = trial._root, trial.total_bytes
        for name, _value in changes:
            self._notify(name)

    def _growth(self, parts: list[str], node: Node) -> int:
        """How many bytes setting ``node`` at ``parts`` adds: its own, the names created on
        the way, less what it replaces (the old node there, a value that becomes a namespace)."""
        if not parts:
            return _size(node) - _size(self._root)
        growth = _size(node)
        here: Node | None = self._root
        for p in parts[:-1]:
            child = here.get(p) if isinstance(here, dict) else None
            if child is None:
                growth += len(p)  # a new namespace
            elif not isinstance(child, dict):
                growth -= _size(child)  # a value that becomes a namespace keeps its name
                child = None
            here = child
        old = here.get(parts[-1]) if isinstance(here, dict) else None
        return growth + (len(parts[-1]) if old is None else -_size(old))

    def _node(self, name: str) -> Node | None:
        node: Node = self._root
        for p in self._parts(name):
            if not isinstance(node, dict) or p not in node:
                return None
            node = node[p]
        return node

    def get(self, name: str, default: Any = _MISSING) -> Any:
        node = self._node(name)
        if node is None:
            if default is _MISSING:
                raise KeyError(name)
            return default
        return orjson.loads(_to_json(node))

    def get_json(self, name: str, default: Any = None) -> bytes:
        """The value (or ``default``) as JSON text, composed from the stored texts."""
        node = self._node(name)
        return orjson.dumps(default) if node is None else _to_json(node)

    def has(self, name: str) -> bool:
        return self._node(name) is not None

    def delete(self, name: str) -> bool:
        parts = self._parts(name)
        if not parts:
            self._root = {}
            self.total_bytes = 0
            self._notify(name)
            return True
        parent = self._node("/" + "/".join(parts[:-1]))
        if isinstance(parent, dict) and parts[-1] in parent:
            self.total_bytes -= _size(parent.pop(parts[-1])) + sum(map(len, parts))
            self._notify(name)
            return True
        return False

    def names(self) -> list[str]:
        """Every leaf name (a value, or an empty namespace), as rosapi's get_param_names."""
        out: list[str] = []
        stack: list[tuple[Node, str]] = [(self._root, "")]
        while stack:
            node, prefix = stack.pop()
            if isinstance(node, dict) and node:
                stack.extend((child, f"{prefix}/{key}") for key, child in node.items())
            elif prefix:
                out.append(prefix)
        return sorted(out)

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


def _parse(data: bytes) -> Any:
    """``orjson.loads`` with the cyclic garbage collector paused: the objects it makes are
    freed (by reference counting) as soon as the value is stored as text, yet their creation
    would trigger collections that walk the whole server (a 1 MB ``[[],[],…]``: 570 ms
    instead of 40)."""
    return without_gc(orjson.loads, data)


def without_gc(parse: Callable[[Any], Any], data: Any) -> Any:
    """``parse(data)`` with the cyclic garbage collector paused (a parser making many
    short-lived objects; the Foxglove session's JSON ops use it too)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        return parse(data)
    finally:
        if was_enabled:
            gc.enable()


def _as_node(value: Any, data: bytes) -> Node:
    """A parsed value as a node: a dictionary becomes a namespace whose leaves are the JSON
    texts of its items; anything else is kept as the text it came in."""
    if not isinstance(value, dict):
        return data
    root: dict[str, Node] = {}
    stack = [(value, root)]
    while stack:
        source, target = stack.pop()
        for key, item in source.items():
            if isinstance(item, dict):
                child: dict[str, Node] = {}
                target[key] = child
                stack.append((item, child))
            else:
                target[key] = orjson.dumps(item)
    return root


def _copy_tree(root: dict[str, Node]) -> dict[str, Node]:
    """The namespaces of a tree copied (its JSON texts shared: bytes never change)."""
    copy: dict[str, Node] = {}
    stack = [(root, copy)]
    while stack:
        source, target = stack.pop()
        for key, node in source.items():
            if isinstance(node, dict):
                child: dict[str, Node] = {}
                target[key] = child
                stack.append((node, child))
            else:
                target[key] = node
    return copy


def _size(node: Node) -> int:
    """Bytes a node holds: its texts and the names inside it."""
    total = 0
    stack = [node]
    while stack:
        item = stack.pop()
        if isinstance(item, bytes):
            total += len(item)
        else:
            for key, child in item.items():
                total += len(key)
                stack.append(child)
    return total


def _to_json(node: Node) -> bytes:
    """A node as one JSON text: namespaces become objects around the stored texts. Built with
    an explicit stack of open objects, not recursion."""
    if isinstance(node, bytes):
        return node
    out: list[bytes] = [b"{"]
    stack = [iter(node.items())]
    first = [True]
    while stack:
        entry = next(stack[-1], None)
        if entry is None:
            stack.pop()
            first.pop()
            out.append(b"}")
            continue
        key, child = entry
        out.append((b"" if first[-1] else b",") + orjson.dumps(key) + b":")
        first[-1] = False
        if isinstance(child, bytes):
            out.append(child)
        else:
            out.append(b"{")
            stack.append(iter(child.items()))
            first.append(True)
    return b"".join(out)

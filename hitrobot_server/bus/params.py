"""A ROS-1-style parameter server: a tree of values addressed by slash-separated names."""

from __future__ import annotations

import copy
import logging
from collections.abc import Callable
from typing import Any

from .names import canonical

_MISSING = object()
log = logging.getLogger(__name__)


class ParamStore:
    """Nested dict keyed by name segments, so ``get('/a')`` returns the subtree like rosparam."""

    def __init__(self) -> None:
        self._root: dict[str, Any] = {}
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
        parts = self._parts(name)
        if not parts:
            if not isinstance(value, dict):
                raise ValueError("the root parameter '/' can only be set to a dictionary")
            self._root = copy.deepcopy(value)
            self._notify(name)
            return
        node = self._root
        for p in parts[:-1]:
            child = node.get(p)
            if not isinstance(child, dict):
                child = node[p] = {}
            node = child
        node[parts[-1]] = copy.deepcopy(value)
        self._notify(name)

    def get(self, name: str, default: Any = _MISSING) -> Any:
        node: Any = self._root
        for p in self._parts(name):
            if not isinstance(node, dict) or p not in node:
                if default is _MISSING:
                    raise KeyError(name)
                return default
            node = node[p]
        return copy.deepcopy(node)

    def has(self, name: str) -> bool:
        absent = object()
        return self.get(name, absent) is not absent

    def delete(self, name: str) -> bool:
        parts = self._parts(name)
        if not parts:
            self._root = {}
            self._notify(name)
            return True
        node: Any = self._root
        for p in parts[:-1]:
            if not isinstance(node, dict) or p not in node:
                return False
            node = node[p]
        if isinstance(node, dict) and parts[-1] in node:
            del node[parts[-1]]
            self._notify(name)
            return True
        return False

    def names(self) -> list[str]:
        """Every leaf name, as rosapi's get_param_names lists them."""
        out: list[str] = []

        def walk(prefix: str, node: dict[str, Any]) -> None:
            for key, value in node.items():
                full = f"{prefix}/{key}"
                if isinstance(value, dict) and value:
                    walk(full, value)
                else:
                    out.append(full)

        walk("", self._root)
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

"""One robot's state folder: opened before its nodes start (the simulator's identity is known
at once), or bound once a REST robot says who it is (and again when another robot answers at
the same address). The log says what came back, and which side won on a (re)connect."""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Awaitable, Callable
from pathlib import Path

from .nodes.assembly import restored_summary
from .nodes.base import Node
from .robot.backend import BackendError
from .robot.composed import ComposedBackend
from .state import StateBinding, StateStore, identity_folder

log = logging.getLogger(__name__)

BIND_POLL = 0.5
IDENTITY_RECHECK = 5.0
"""Seconds between asking a connected REST robot who it is (a swap keeps the address)."""


def rest_identity(device_id: str, url: str) -> str:
    """A REST robot's identity: its device id (serial), or its address if it gives none."""
    return f"slamware-{device_id}" if device_id else f"slamware-at-{url}"


async def open_state(root: Path, identity: str, fresh: bool) -> StateStore:
    """One robot identity's state folder, read (off the event loop) before anything starts."""
    return await asyncio.to_thread(StateStore.open, identity_folder(root, identity), fresh)


def report_restored(store: StateStore, phrases: list[str]) -> None:
    """The start-up line: what came back and from where, or that the robot starts fresh."""
    restored = store.restored
    restored.fresh = not phrases
    restored.summary = ", ".join(phrases)
    if phrases:
        log.info("state: restored %s from %s", restored.summary, store.path)
    else:
        log.info("state: started fresh in %s", store.path)


class RestStateBinder:
    """Whenever a REST robot (re)connects, and every few seconds while it is connected (a
    robot swapped at the same address may never look disconnected), ask who it is; a new
    identity gets its own state folder, and the log says which side's state won."""

    def __init__(self, backend: ComposedBackend, binding: StateBinding, url: str, root: Path,
                 fresh: bool, nodes: Callable[[], list[Node]],
                 on_bound: Callable[[StateStore], Awaitable[None]] | None = None):
        """``on_bound``: told each folder bound, before the nodes adopt it (the site takes
        what its first robot's folder kept for it)."""
        self.backend, self.binding, self.url = backend, binding, url
        self.root, self.fresh, self.nodes = root, fresh, nodes
        self.on_bound = on_bound

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        was, asked = False, -math.inf
        while True:
            now = self.backend.link.connected
            if now and (not was or loop.time() - asked >= IDENTITY_RECHECK):
                asked = loop.time()
                try:
                    info = await self.backend.sensors.get_device_info()
                except BackendError as exc:
                    log.warning("state: cannot ask the robot who it is (%s); retrying", exc)
                    now = False
                else:
                    identity = rest_identity(info.device_id, self.url)
                    if identity != self.binding.identity:
                        try:
                            await self._bind(identity)
                        except OSError as exc:  # held by another server, or not writable
                            log.error("state: the robot %s cannot be bound to its state "
                                      "folder: %s; asking again in %.0f s", identity, exc,
                                      IDENTITY_RECHECK)
                    elif not was:
                        log.info(
                            "state: robot %s reconnected: the robot's side stands for its map, "
                            "walls, tracks, home and pose (the server pushes none of them); the "
                            "server's side for its POIs, layers, routes and graphs, and its "
                            "masks are handed over again as the robot's blocked areas",
                            identity)
            was = now
            await asyncio.sleep(BIND_POLL)

    async def _bind(self, identity: str) -> None:
        binding = self.binding
        old, changed = binding.identity, binding.changed_unbound
        store = await open_state(self.root, identity, self.fresh and not old)
        if binding.store is not None:
            await binding.store.close()
        binding.store, binding.identity, binding.changed_unbound = store, identity, False
        if self.on_bound is not None:
            await self.on_bound(store)
        nodes = self.nodes()
        if old:
            why = f"a different robot ({identity}, was {old}) answers at {self.url}"
            restore = True
        elif changed:
            why = ("the server's state was changed while the robot was not reached yet, so it is "
                   "newer than the folder's")
            restore = False
        else:
            why = "nothing was changed before the robot was reached"
            restore = True
        for node in nodes:
            node.adopt(restore)
        if restore:
            report_restored(store, restored_summary(nodes))
            log.info("state: the state folder won: %s", why)
        else:
            kept = await asyncio.to_thread(store.keep_copy, "superseded")
            store.restored.fresh, store.restored.summary = True, "nothing (the server's won)"
            log.info("state: the server's state won over %s: %s (the folder's state is kept "
                     "at %s)", store.path, why, kept)

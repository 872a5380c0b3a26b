"""The site of a server with named robots, as a part of its own: its state folder
(``<state-dir>/site/``), its nodes (rosapi, TF, the bridge's diagnostics, the fleet with its
tasks, schedules and zones) and its map manager (POIs, masks, the composed ``/map``, saved
maps), fed by one robot's map (``--site-map-robot``, the first robot by default).

What the site keeps is its own: removing or renaming a robot, or choosing another one to feed
the map, loses none of it. A server that kept the site's map-manager sections in its first
robot's folder (before the site had a part of its own) has them moved into the site's folder on
its first start (:mod:`.state.moving`: all or nothing, once). A single unnamed robot has no
site part: its map manager and its folder stay as they were.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path

from .bus.core import Bus
from .config import Settings
from .nodes.assembly import restored_summary, site_map, start_site_nodes, stop_nodes
from .nodes.base import Node
from .nodes.map_manager import MEMORY
from .nodes.options import NodeOptions
from .robot.capabilities import Robot
from .robot_state import open_state, report_restored
from .state import StateBinding, StateStore, identity_folder
from .state.moving import finish_move, move_sections, moving_from

log = logging.getLogger(__name__)

SITE_IDENTITY = "site"
"""The site's state folder: ``<state-dir>/site/`` (a robot's is ``sim-…`` or ``slamware-…``)."""
MOVED = "site/moved"
"""The site folder's mark of the one move of a robot's map-manager sections into it."""


@dataclass
class SiteUnit:
    """The site: ``nodes`` start first and stop last; ``map_manager`` starts with the robot
    that feeds it and stops before any robot."""

    state: StateBinding = field(default_factory=StateBinding)
    nodes: list[Node] = field(default_factory=list)
    map_manager: Node | None = None


async def start_site(bus: Bus, settings: Settings, moved_from: str | None, *,
                     later: bool = False) -> SiteUnit:
    """Open the site's folder, move ``moved_from``'s map-manager sections into it the first
    time (the folder of the robot that held them; ``later``: a REST robot's, known once it
    answers, :func:`move_in_bound`), and start the site's nodes; on failure whatever was opened
    is closed again."""
    store = settings.store
    site = SiteUnit(StateBinding(await open_state(store.state_root, SITE_IDENTITY, store.fresh),
                                 SITE_IDENTITY))
    try:
        await move_in(site.state, store.state_root, moved_from, store.fresh, later=later)
        site.nodes = await start_site_nodes(bus, settings.node_options(), site.state)
    except BaseException:
        await stop_site(site)
        raise
    return site


async def attach_site_map(site: SiteUnit, bus: Bus, settings: NodeOptions,
                          robot: Robot) -> None:
    """Start the site's map manager on the feeding robot's view ``bus`` (held before it
    starts: a REST robot bound meanwhile hands it what it moved, :func:`move_in_bound`)."""
    site.map_manager = site_map(bus, settings, robot, site.state)
    await site.map_manager.start()


def report_site(site: SiteUnit) -> None:
    """The site folder's start-up line: what its parts took back."""
    if site.state.store is not None:
        parts = [*site.nodes, *([site.map_manager] if site.map_manager else [])]
        report_restored(site.state.store, restored_summary(parts))


async def stop_site_map(site: SiteUnit) -> None:
    """The map manager first: it drives its robot, which stops after it."""
    if site.map_manager is not None:
        await stop_nodes([site.map_manager])
        site.map_manager = None


async def stop_site(site: SiteUnit) -> None:
    """The site's nodes, then its folder (after the robots: the fleet drives them)."""
    await stop_site_map(site)
    await stop_nodes(site.nodes)
    site.nodes.clear()
    if site.state.store is not None:
        await site.state.store.close()
        site.state = StateBinding()


async def move_in(state: StateBinding, root: Path, moved_from: str | None, fresh: bool, *,
                  later: bool = False) -> None:
    """The site's map-manager sections from ``moved_from``'s folder, once: a move cut short by
    a crash is finished, a finished one is not done again, ``--fresh`` moves nothing, and
    ``later`` leaves it to :func:`move_in_bound`."""
    site = state.store
    assert site is not None
    if (unfinished := moving_from(site, MOVED)) is not None:
        await _with_store(root / unfinished, lambda old: finish_move(old, site, MOVED))
        return
    if site.get(MOVED) is not None or (later and not fresh):
        return
    folder = identity_folder(root, moved_from) if moved_from else None
    if fresh or folder is None or not folder.is_dir():
        await site.put(MOVED, {"from": "", "sections": [], "cleared": True})
        return

    await _with_store(folder, lambda old: _move(old, site))


async def move_in_bound(site: SiteUnit, old: StateStore) -> None:
    """A REST robot that fed the site's map manager before the site had a folder of its own
    was bound to its folder (``old``): the site's sections move from it, the first time, and
    the map manager takes them. A move that fails is logged and tried again, or finished, at
    the next start (the robot's folder keeps them until the site's has them)."""
    target = site.state.store
    if target is None or target.get(MOVED) is not None:
        return
    try:
        await _move(old, target)
    except OSError as exc:
        log.error("state: moving the site's sections from %s did not finish (%s); the next "
                  "start goes on with it", old.path, exc)
    if site.map_manager is not None and target.get(MOVED) is not None:
        site.map_manager.adopt(True)  # the site's folder has them


async def _move(old: StateStore, site: StateStore) -> None:
    names = await move_sections(old, site, f"{MEMORY}/", MOVED)
    log.info("state: the site's %s moved from %s to %s", ", ".join(names) or "nothing",
             old.path, site.path)
    if kept := old.keys(f"{MEMORY}/"):
        log.warning("state: %s stay in %s: the site's own are newer", ", ".join(kept), old.path)


async def _with_store(folder: Path, work: Callable[[StateStore], Awaitable[None]]) -> None:
    old = await asyncio.to_thread(StateStore.open, folder)
    try:
        await work(old)
    finally:
        await old.close()

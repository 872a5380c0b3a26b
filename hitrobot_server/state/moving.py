"""Sections moved from one state folder into another, once (a robot's map-manager sections
into the site's folder, when a fleet server first starts with the site as a part of its own).

Why it cannot lose anything: the sections and a mark (where they came from, which they were)
are put into the target together, before anything awaits, so the target's writer commits them
as one journal line: after a crash the target has all of them and the mark, or none. Only once
that line is on disk are they removed from the source, and the mark then says so; a crash in
between leaves the source's copies, which :func:`finish_move` removes on the next start. A
target holding the mark is never moved into again.
"""

from __future__ import annotations

import asyncio
from typing import Any

from .store import StateStore


async def move_sections(source: StateStore, target: StateStore, prefix: str,
                        mark: str) -> list[str]:
    """Move every section of ``source`` under ``prefix`` into ``target`` (a section the target
    has already keeps the target's value) and put ``mark``; the names moved. Raises
    :class:`~.store.StateWriteError` when the target could not be written (the source is then
    untouched)."""
    names = [key for key in source.keys(prefix) if target.get(key) is None]
    puts = [target.put(key, source.get(key)) for key in names]
    puts.append(target.put(mark, {"from": source.path.name, "sections": names,
                                  "cleared": False}))
    await _durable(puts)  # put without a pause between them: one batch, one line
    await finish_move(source, target, mark)
    return names


async def finish_move(source: StateStore, target: StateStore, mark: str) -> None:
    """Remove the moved sections from ``source`` (those it still has), then mark the move
    finished; nothing when ``target``'s mark says it is."""
    record: Any = target.get(mark)
    if not isinstance(record, dict) or record.get("cleared"):
        return
    names = [key for key in record.get("sections", []) if source.get(key) is not None]
    if names:
        await _durable([source.put(key, None) for key in names])
    await target.put(mark, {**record, "cleared": True})


def moving_from(target: StateStore, mark: str) -> str | None:
    """The folder name an unfinished move into ``target`` came from (``None``: no move, or a
    finished one)."""
    record = target.get(mark)
    if isinstance(record, dict) and not record.get("cleared"):
        return str(record.get("from", "")) or None
    return None


async def _durable(puts: list[asyncio.Future]) -> None:
    """Once every put is on disk; the first failure raised (each one retrieved)."""
    for outcome in await asyncio.gather(*puts, return_exceptions=True):
        if isinstance(outcome, BaseException):
            raise outcome

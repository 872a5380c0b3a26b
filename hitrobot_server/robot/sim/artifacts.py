"""Virtual walls and tracks, kept by id per usage the way the robot keeps them."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from ..model import ArtifactUsage, Line


class LineStore:
    """Lines per usage. ``revision`` changes on every edit so costmaps know to rebuild."""

    def __init__(self) -> None:
        self._lines: dict[ArtifactUsage, dict[int, Line]] = {u: {} for u in ArtifactUsage}
        self._next_id = 1
        self.revision = 0

    def get(self, usage: ArtifactUsage) -> list[Line]:
        return list(self._lines[usage].values())

    def add(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        """Store ``lines``; a non-zero id not yet used (in any usage) is kept, otherwise a fresh
        id is assigned. Returns the stored lines."""
        stored = []
        for line in lines:
            lid = line.id
            if lid == 0 or self._in_use(lid):
                lid = self._fresh_id()
            self._next_id = max(self._next_id, lid + 1)
            kept = replace(line, id=lid)
            self._lines[usage][lid] = kept
            stored.append(kept)
        self.revision += 1
        return stored

    def remove(self, usage: ArtifactUsage, line_id: int) -> bool:
        found = self._lines[usage].pop(line_id, None) is not None
        self.revision += found
        return found

    def clear(self, usage: ArtifactUsage) -> None:
        self._lines[usage].clear()
        self.revision += 1

    def move(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        """Update existing lines by id; True only if every id existed."""
        table = self._lines[usage]
        known = [line for line in lines if line.id in table]
        for line in known:
            table[line.id] = line
        self.revision += 1
        return len(known) == len(lines)

    def replace_all(self, usage: ArtifactUsage, lines: Sequence[Line]) -> None:
        """Install ``lines`` with their ids (loading a composite map)."""
        self._lines[usage] = {line.id: line for line in lines}
        if lines:
            self._next_id = max(self._next_id, max(line.id for line in lines) + 1)
        self.revision += 1

    def _in_use(self, lid: int) -> bool:
        return any(lid in table for table in self._lines.values())

    def _fresh_id(self) -> int:
        while self._in_use(self._next_id):
            self._next_id += 1
        return self._next_id

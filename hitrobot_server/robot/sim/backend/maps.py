"""The simulated robot's map: explore map, lines, blocked areas, home, whole-map transfer.
What it remembers is answered once on disk."""

from __future__ import annotations

from collections.abc import Sequence

from ... import composite_map
from ...backend import MapBackend, UnsupportedError
from ...model import ArtifactUsage, Line, MapKind, MapRegion, Point2D, Pose2D, Rect
from ..runner import RunnerPart

EXPLORE = MapKind.EXPLORERMAP


class SimMaps(RunnerPart, MapBackend):
    async def get_known_area(self, kind: MapKind = EXPLORE) -> Rect:
        explore_only(kind)
        return self.runner.call(self.runner.simulator.map.known_area)

    async def get_map(self, area: Rect | None = None, kind: MapKind = EXPLORE) -> MapRegion:
        explore_only(kind)
        return self.runner.call(self.runner.simulator.map.map_region, area)

    async def clear_map(self, kind: MapKind = EXPLORE) -> None:
        explore_only(kind)
        await self.runner.change(self.runner.simulator.map.clear_map)

    async def get_map_update(self, kind: MapKind = EXPLORE) -> bool:
        explore_only(kind)
        return self.runner.call(lambda: self.runner.simulator.map.map_update)

    async def set_map_update(self, enabled: bool, kind: MapKind = EXPLORE) -> None:
        explore_only(kind)
        await self.runner.change(setattr, self.runner.simulator.map, "map_update", enabled)

    async def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        return self.runner.call(self.runner.simulator.map.get_lines, usage)

    async def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        return await self.runner.change(self.runner.simulator.map.add_lines, usage, lines)

    async def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        return await self.runner.change(self.runner.simulator.map.remove_line, usage, line_id)

    async def clear_lines(self, usage: ArtifactUsage) -> None:
        await self.runner.change(self.runner.simulator.map.clear_lines, usage)

    async def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        return await self.runner.change(self.runner.simulator.map.move_lines, usage, lines)

    async def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        self.runner.call(self.runner.simulator.map.set_blocked_areas, areas)

    async def get_home_pose(self) -> Pose2D | None:
        return self.runner.call(lambda: self.runner.simulator.map.home_pose)

    async def set_home_pose(self, pose: Pose2D) -> None:
        await self.runner.change(setattr, self.runner.simulator.map, "home_pose", pose)

    async def get_composite_map(self) -> bytes:
        return self.runner.call(self.runner.simulator.map.composite_map)

    async def check_composite_map(self, data: bytes) -> None:
        self.runner.call(self.runner.simulator.map.check_composite_map, data)

    async def set_composite_map(self, data: bytes, pose: Pose2D) -> None:
        await self.runner.change(self.runner.simulator.load_composite_map, data, pose)

    async def install_map(self, explore: MapRegion | None, walls: Sequence[Line],
                          tracks: Sequence[Line], home: Pose2D | None, pose: Pose2D) -> None:
        """Through the simulator's own container, so the content is checked completely, as a
        loaded file is, before anything changes."""
        await self.set_composite_map(composite_map.encode(composite_map.CompositeMap(
            explore, tuple(walls), tuple(tracks), home)), pose)


def explore_only(kind: MapKind) -> None:
    if kind != MapKind.EXPLORERMAP:
        raise UnsupportedError(f"the simulator only has an explore map, not {kind!r}")

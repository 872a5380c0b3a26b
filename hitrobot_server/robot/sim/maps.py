"""The map requests of the simulated robot (:class:`MapRequests`, a part of
:class:`~.simulator.Simulator`): its explore map, virtual lines, blocked areas, home dock and
the whole map as composite-map bytes."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from .. import composite_map
from ..model import ArtifactUsage, Line, MapRegion, Point2D, Pose2D, Rect
from .artifacts import LineStore
from .checks import checked_line, checked_pose
from .mapping import ExploreMapper

if TYPE_CHECKING:
    from .world import World


class MapRequests:
    """What the robot keeps on its map: the explore map (``_mapper``), the virtual walls and
    tracks (``_lines``), the blocked areas and the home dock; bad arguments raise
    ``ValueError``. The planner's costmap is rebuilt from them when a revision changes."""

    world: World
    _mapper: ExploreMapper
    _lines: LineStore
    _blocked: tuple[tuple[Point2D, ...], ...]
    _blocked_revision: int
    _home: Pose2D | None
    if TYPE_CHECKING:
        def set_pose(self, pose: Pose2D) -> None: ...

    @property
    def map_update(self) -> bool:
        return self._mapper.enabled

    @map_update.setter
    def map_update(self, enabled: bool) -> None:
        self._mapper.enabled = bool(enabled)

    def known_area(self) -> Rect:
        return self._mapper.known_area()

    def map_region(self, area: Rect | None = None) -> MapRegion:
        return self._mapper.region(area)

    def clear_map(self) -> None:
        self._mapper.clear()

    @property
    def home_pose(self) -> Pose2D | None:
        return self._home

    @home_pose.setter
    def home_pose(self, pose: Pose2D) -> None:
        self._home = checked_pose(pose)

    def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        return self._lines.get(ArtifactUsage(usage))

    def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        return self._lines.add(ArtifactUsage(usage), [checked_line(line) for line in lines])

    def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        return self._lines.remove(ArtifactUsage(usage), line_id)

    def clear_lines(self, usage: ArtifactUsage) -> None:
        self._lines.clear(ArtifactUsage(usage))

    def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        return self._lines.move(ArtifactUsage(usage), [checked_line(line) for line in lines])

    def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        self._blocked = tuple(tuple(polygon) for polygon in areas)
        self._blocked_revision += 1

    def composite_map(self) -> bytes:
        """The map, lines and home as :mod:`~hitrobot_server.robot.composite_map` bytes."""
        known = self._mapper.known_area()
        cmap = composite_map.CompositeMap(
            explore=None if known.is_empty else self._mapper.region(known),
            walls=tuple(self._lines.get(ArtifactUsage.VIRTUAL_WALL)),
            tracks=tuple(self._lines.get(ArtifactUsage.VIRTUAL_TRACK)),
            home=self._home,
        )
        return composite_map.encode(cmap)

    def check_composite_map(self, data: bytes) -> composite_map.CompositeMap:
        """The decoded map if :meth:`load_composite_map` would take it; ``ValueError`` if
        not (checked completely, so loading cannot fail half-way)."""
        cmap = composite_map.decode(data)
        res = self.world.spec.resolution
        if cmap.explore is not None and abs(cmap.explore.resolution - res) > 1e-6:
            raise ValueError(f"map resolution {cmap.explore.resolution} differs from {res}")
        return cmap

    def load_composite_map(self, data: bytes, pose: Pose2D) -> None:
        """Install a composite map and set the believed pose; ``ValueError`` (and nothing
        changed) if either is invalid."""
        pose = checked_pose(pose)
        cmap = self.check_composite_map(data)
        if cmap.explore is None:
            self._mapper.clear()
        else:
            self._mapper.load(cmap.explore)
        self._lines.replace_all(ArtifactUsage.VIRTUAL_WALL, cmap.walls)
        self._lines.replace_all(ArtifactUsage.VIRTUAL_TRACK, cmap.tracks)
        self._home = cmap.home
        self.set_pose(pose)

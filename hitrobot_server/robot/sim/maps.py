"""What the simulated robot keeps on its map (:class:`RobotMap`, a part of
:class:`~.simulator.Simulator`): its explore map, virtual lines, blocked areas and home dock,
the whole map as composite-map bytes, what of it survives a restart, and the planner's
costmap built of them."""

from __future__ import annotations

from collections.abc import Sequence

from .. import composite_map
from ..model import ArtifactUsage, Line, MapRegion, Point2D, Pose2D, Rect
from ..planning.costmap import Costmap, CostmapConfig, build_costmap
from .artifacts import LineStore
from .checks import checked_line, checked_pose
from .mapping import ExploreMapper

WALL, TRACK = ArtifactUsage.VIRTUAL_WALL, ArtifactUsage.VIRTUAL_TRACK


class RobotMap:
    """The explore map (``mapper``), the virtual walls and tracks, the blocked areas and the
    home dock; bad arguments raise ``ValueError``. The costmap is rebuilt from them when a
    revision changes."""

    def __init__(self, mapper: ExploreMapper, home: Pose2D | None,
                 costmap: CostmapConfig) -> None:
        self.mapper = mapper
        self.lines = LineStore()
        self.blocked: tuple[tuple[Point2D, ...], ...] = ()
        self._blocked_revision = 0
        self._home = home
        self._config = costmap
        self._costmap: Costmap | None = None
        self._costmap_key: tuple[int, int, int] | None = None

    @property
    def map_update(self) -> bool:
        return self.mapper.enabled

    @map_update.setter
    def map_update(self, enabled: bool) -> None:
        self.mapper.enabled = bool(enabled)

    def known_area(self) -> Rect:
        return self.mapper.known_area()

    def map_region(self, area: Rect | None = None) -> MapRegion:
        return self.mapper.region(area)

    def clear_map(self) -> None:
        self.mapper.clear()

    @property
    def home_pose(self) -> Pose2D | None:
        return self._home

    @home_pose.setter
    def home_pose(self, pose: Pose2D) -> None:
        self._home = checked_pose(pose)

    def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        return self.lines.get(ArtifactUsage(usage))

    def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        return self.lines.add(ArtifactUsage(usage), [checked_line(line) for line in lines])

    def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        return self.lines.remove(ArtifactUsage(usage), line_id)

    def clear_lines(self, usage: ArtifactUsage) -> None:
        self.lines.clear(ArtifactUsage(usage))

    def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        return self.lines.move(ArtifactUsage(usage), [checked_line(line) for line in lines])

    def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        self.blocked = tuple(tuple(polygon) for polygon in areas)
        self._blocked_revision += 1

    def costmap(self) -> Costmap:
        """The planner's map of the explore map, the lines and the blocked areas (built again
        when one of them changed)."""
        key = (self.mapper.revision, self.lines.revision, self._blocked_revision)
        if self._costmap is None or key != self._costmap_key:
            cells = self.mapper.cells()
            self._costmap = build_costmap(
                self.mapper.spec, cells >= 128, cells == 0, self._config,
                walls=self.lines.get(WALL), blocked=self.blocked, tracks=self.lines.get(TRACK))
            self._costmap_key = key
        return self._costmap

    # --- the whole map as bytes --------------------------------------------------------------

    def composite_map(self) -> bytes:
        """The map, lines and home as :mod:`~hitrobot_server.robot.composite_map` bytes."""
        return composite_map.encode(composite_map.CompositeMap(
            explore=self._explored(), walls=tuple(self.lines.get(WALL)),
            tracks=tuple(self.lines.get(TRACK)), home=self._home))

    def check_composite_map(self, data: bytes) -> composite_map.CompositeMap:
        """The decoded map if :meth:`install` would take it; ``ValueError`` if not (checked
        completely, so installing cannot fail half-way)."""
        cmap = composite_map.decode(data)
        res = self.mapper.spec.resolution
        if cmap.explore is not None and abs(cmap.explore.resolution - res) > 1e-6:
            raise ValueError(f"map resolution {cmap.explore.resolution} differs from {res}")
        return cmap

    def install(self, cmap: composite_map.CompositeMap) -> None:
        """Replace the explore map, the lines and the home with a checked composite map."""
        self._load(cmap.explore)
        self.lines.replace_all(WALL, cmap.walls)
        self.lines.replace_all(TRACK, cmap.tracks)
        self._home = cmap.home

    def _explored(self) -> MapRegion | None:
        known = self.mapper.known_area()
        return None if known.is_empty else self.mapper.region(known)

    def _load(self, explore: MapRegion | None) -> None:
        if explore is None:
            self.mapper.clear()
        else:
            self.mapper.load(explore)

    # --- what survives a restart -------------------------------------------------------------

    def saved_lines(self) -> dict:
        """Virtual walls, tracks and the home pose as JSON."""
        def rows(usage: ArtifactUsage) -> list[list[float]]:
            return [[line.id, line.start.x, line.start.y, line.end.x, line.end.y]
                    for line in self.lines.get(usage)]

        home = self._home
        return {"walls": rows(WALL), "tracks": rows(TRACK),
                "home": None if home is None else [home.x, home.y, home.yaw]}

    def restore_lines(self, saved: dict) -> None:
        """Install what :meth:`saved_lines` gave; ``ValueError`` (nothing changed) if bad."""
        try:
            lines = {usage: [checked_line(Line(int(i), Point2D(float(x0), float(y0)),
                                               Point2D(float(x1), float(y1))))
                             for i, x0, y0, x1, y1 in saved[key]]
                     for key, usage in (("walls", WALL), ("tracks", TRACK))}
            home = saved["home"]
            home = None if home is None else checked_pose(Pose2D(*map(float, home)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"not saved lines ({exc})") from None
        for usage, items in lines.items():
            if len({line.id for line in items}) != len(items):
                raise ValueError("two lines share an id")
            self.lines.replace_all(usage, items)
        self._home = home

    @property
    def map_revision(self) -> int:
        return self.mapper.revision

    def saved_map(self) -> bytes:
        """The explore map alone, in our composite-map container."""
        return composite_map.encode(composite_map.CompositeMap(
            explore=self._explored(), walls=(), tracks=(), home=None))

    def restore_map(self, data: bytes) -> None:
        """Install a map :meth:`saved_map` gave; ``ValueError`` (nothing changed) if bad."""
        self._load(self.check_composite_map(data).explore)

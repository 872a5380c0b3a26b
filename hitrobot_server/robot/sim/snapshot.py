"""What the simulated robot keeps across a restart, as JSON and bytes (:class:`SavedState`, a
part of :class:`~.simulator.Simulator`); :mod:`.persist` writes it to the state folder."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import composite_map
from ..model import ArtifactUsage, Line, Point2D, Pose2D
from .artifacts import LineStore
from .checks import checked_line, checked_pose
from .kinematics import DiffDrive
from .localization import Localizer
from .mapping import ExploreMapper
from .power import Battery

if TYPE_CHECKING:
    from .config import SimConfig


class SavedState:
    """The chassis (pose, battery, localization), the lines and home, and the explore map,
    saved and restored; a restore refuses (``ValueError``, nothing changed) what it cannot
    take."""

    config: SimConfig
    _drive: DiffDrive
    _localizer: Localizer
    _battery: Battery
    _lines: LineStore
    _mapper: ExploreMapper
    _home: Pose2D | None
    if TYPE_CHECKING:
        @property
        def pose(self) -> Pose2D: ...

        @property
        def localization_enabled(self) -> bool: ...

        @localization_enabled.setter
        def localization_enabled(self, enabled: bool) -> None: ...

        def _clearance(self, x: float, y: float) -> float: ...

        def _sense(self) -> None: ...

        def check_composite_map(self, data: bytes) -> composite_map.CompositeMap: ...

    def saved_robot(self) -> dict:
        """The chassis as JSON: true and believed pose, battery, localization. (Mapping is a
        mode the robot starts without, as after a reboot.)"""
        t, b = self._drive.pose, self.pose
        return {"pose": [t.x, t.y, t.yaw], "believed": [b.x, b.y, b.yaw],
                "battery": round(self._battery.percentage, 2),
                "localization": self._localizer.enabled}

    def restore_robot(self, saved: dict) -> None:
        """Put the chassis back where :meth:`saved_robot` found it; ``ValueError`` (nothing
        changed) if ``saved`` is not such a record or the pose is not in free space."""
        try:
            pose = checked_pose(Pose2D(*map(float, saved["pose"])))
            believed = checked_pose(Pose2D(*map(float, saved["believed"])))
            battery = float(saved["battery"])
            localization = saved["localization"]
        except (KeyError, TypeError) as exc:
            raise ValueError(f"not a saved robot state ({exc})") from None
        if not (0.0 <= battery <= 100.0) or not isinstance(localization, bool):
            raise ValueError("battery or localization out of range")
        if self._clearance(pose.x, pose.y) < self.config.drive.radius * 0.5:
            raise ValueError(f"the saved pose ({pose.x:.2f}, {pose.y:.2f}) is inside an obstacle")
        self._drive.pose = pose
        self._drive.linear = self._drive.angular = 0.0
        self._localizer.set_pose(believed, pose)
        self.localization_enabled = localization
        self._battery.percentage = battery
        self._sense()

    def saved_lines(self) -> dict:
        """Virtual walls, tracks and the home pose as JSON."""
        def rows(usage: ArtifactUsage) -> list[list[float]]:
            return [[line.id, line.start.x, line.start.y, line.end.x, line.end.y]
                    for line in self._lines.get(usage)]

        home = self._home
        return {"walls": rows(ArtifactUsage.VIRTUAL_WALL),
                "tracks": rows(ArtifactUsage.VIRTUAL_TRACK),
                "home": None if home is None else [home.x, home.y, home.yaw]}

    def restore_lines(self, saved: dict) -> None:
        """Install what :meth:`saved_lines` gave; ``ValueError`` (nothing changed) if bad."""
        try:
            lines = {usage: [checked_line(Line(int(i), Point2D(float(x0), float(y0)),
                                               Point2D(float(x1), float(y1))))
                             for i, x0, y0, x1, y1 in saved[key]]
                     for key, usage in (("walls", ArtifactUsage.VIRTUAL_WALL),
                                        ("tracks", ArtifactUsage.VIRTUAL_TRACK))}
            home = saved["home"]
            home = None if home is None else checked_pose(Pose2D(*map(float, home)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"not saved lines ({exc})") from None
        for usage, items in lines.items():
            if len({line.id for line in items}) != len(items):
                raise ValueError("two lines share an id")
            self._lines.replace_all(usage, items)
        self._home = home

    @property
    def map_revision(self) -> int:
        return self._mapper.revision

    def saved_map(self) -> bytes:
        """The explore map alone, in our composite-map container."""
        known = self._mapper.known_area()
        return composite_map.encode(composite_map.CompositeMap(
            explore=None if known.is_empty else self._mapper.region(known),
            walls=(), tracks=(), home=None))

    def restore_map(self, data: bytes) -> None:
        """Install a map :meth:`saved_map` gave; ``ValueError`` (nothing changed) if bad."""
        cmap = self.check_composite_map(data)
        if cmap.explore is None:
            self._mapper.clear()
        else:
            self._mapper.load(cmap.explore)

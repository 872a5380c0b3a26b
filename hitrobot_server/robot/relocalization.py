"""Checking a pose guess against the map before believing it (``/set_initialpose``).

A robot told "you are here" must not simply take the guess: a guess 0.6 m or 0.5 rad off leaves
it lost with a good conscience. :func:`refine_guess` runs the coarse-to-fine scan matcher of
the simulator's ``recover_localization`` (:class:`~.planning.matching.RelocalizationSearch`) on
the robot's own explore map and latest lidar frame, searching only near the guess, and says
where the scan really fits and how well. It works for any backend that serves a map and a scan
(the simulator and a Slamware robot over REST alike), and it changes nothing on the robot:
callers commit the refined pose with ``set_pose`` only when the match is good, then confirm
that the robot's own localization quality follows (:data:`GOOD_QUALITY`).
"""

from __future__ import annotations

import asyncio
import math
from dataclasses import dataclass

import numpy as np

from .backend import LocalizationBackend
from .capabilities import Robot
from .model import LaserScan, MapRegion, Pose2D, Rect
from .planning.geometry import compose, inverse, wrap_angle
from .planning.grid import GridSpec, distance_field
from .planning.matching import (
    LikelihoodField,
    LocalizationConfig,
    RelocalizationSearch,
    scan_points,
)

GOOD_QUALITY = 50
"""Localization quality (0-100) that counts as localized."""
MATCH_SCORE = 0.85
"""Mean scan-to-map likelihood (0-1) a refined guess needs before it is committed. The true
pose scores above 0.9 in the simulator; a corridor shifted along itself or a room turned round
still scores 0.65-0.75 (and the robot's quality would then read 65-75), so the bar sits well
above that."""
SEARCH_HALF_SIZE = 1.0
"""Half the side (m) of the square searched around a guess."""
SEARCH_YAW = math.radians(45.0)
"""Half the heading window (rad) searched around a guess: a guess is trusted to this much, so
a scan that fits better turned round (a symmetric corridor) is not taken for the pose."""
CLEARANCE_CELLS = 20
"""Reach (cells) of the distance field the likelihood is built from."""
STAND_CLEARANCE = 0.15
"""A candidate position needs this much room (m) to the nearest obstacle."""


@dataclass(frozen=True, slots=True)
class Refinement:
    """Where the scan fits best near a guess (``pose``, ``None`` when nowhere) and how well
    (``score``, the mean likelihood of its points, 0-1)."""

    pose: Pose2D | None
    score: float

    @property
    def good(self) -> bool:
        return self.pose is not None and self.score >= MATCH_SCORE


def refine_guess(
    region: MapRegion,
    scan: LaserScan,
    guess: Pose2D,
    *,
    half_size: float = SEARCH_HALF_SIZE,
    yaw_window: float = SEARCH_YAW,
    config: LocalizationConfig | None = None,
) -> Refinement:
    """Search ``half_size`` metres and ``yaw_window`` radians around ``guess`` for the pose the
    scan was taken from; the result is that pose moved on by the motion the robot believes it
    made since the scan (so it can be committed as the current pose)."""
    config = config or LocalizationConfig()
    cells = region.cells
    if cells.size == 0:
        return Refinement(None, 0.0)
    spec = GridSpec(region.origin_x, region.origin_y, region.resolution,
                    region.width, region.height)
    occupied = cells >= 128
    clearance = np.where(occupied, 0.0,
                         distance_field(occupied, CLEARANCE_CELLS) * spec.resolution)
    field = LikelihoodField(spec, clearance, config)
    free = (cells > 0) & (cells < 128) & (clearance >= STAND_CLEARANCE)
    points = scan_points(scan.angles, scan.ranges, config.match_points)
    area = Rect(guess.x - half_size, guess.y - half_size, 2 * half_size, 2 * half_size)
    search = RelocalizationSearch(field, points, area, free, config,
                                  yaw_window=(guess.yaw, yaw_window))
    while not search.advance(1 << 22):
        pass
    best = search.best
    if best is None:
        return Refinement(None, 0.0)
    return Refinement(best, search.score)


def carry_forward(at_scan: Pose2D, scan_pose: Pose2D, believed_now: Pose2D) -> Pose2D:
    """``at_scan`` moved on by the robot's own motion from ``scan_pose`` to ``believed_now``."""
    moved = compose(inverse(scan_pose), believed_now)
    pose = compose(at_scan, moved)
    return Pose2D(pose.x, pose.y, wrap_angle(pose.yaw))


QUALITY_SETTLE = 0.5
"""Seconds to let the robot's quality estimate take in new scans after a pose change."""
QUALITY_WAIT = 3.0
"""Seconds to wait, after settling, for the quality to reach :data:`GOOD_QUALITY`."""


async def settled_quality(localization: LocalizationBackend, settle: float = QUALITY_SETTLE,
                          wait: float = QUALITY_WAIT, poll: float = 0.1) -> int:
    """The robot's localization quality once it had time to judge its current pose: read
    after ``settle`` seconds, then polled until it is good or ``wait`` more seconds passed."""
    loop = asyncio.get_running_loop()
    await asyncio.sleep(settle)
    deadline = loop.time() + wait
    quality = await localization.get_localization_quality()
    while quality < GOOD_QUALITY and loop.time() < deadline:
        await asyncio.sleep(poll)
        quality = await localization.get_localization_quality()
    return quality


async def localize_near(robot: Robot, guess: Pose2D) -> tuple[bool, Pose2D, str]:
    """Validate ``guess`` against the map, then commit it: ``(localized, pose, why)``.

    The pose is changed only when the scan matches the map near the guess; after the commit
    the robot's own quality must reach :data:`GOOD_QUALITY`, otherwise the pose it had before
    is restored. ``pose`` is where the robot then believes it is."""
    localization = robot.localization
    before = await localization.get_pose()
    scan = await robot.sensors.get_laser_scan()
    finite = scan.ranges[np.isfinite(scan.ranges)]
    reach = SEARCH_HALF_SIZE + (float(finite.max()) if finite.size else 0.0) + 0.5
    region = await robot.maps.get_map(Rect(guess.x - reach, guess.y - reach, 2 * reach, 2 * reach))
    found = await asyncio.to_thread(refine_guess, region, scan, guess)
    if not found.good or found.pose is None:
        return False, before, (f"the scan does not match the map near the guess "
                               f"(best score {found.score:.2f} < {MATCH_SCORE})")
    now = await localization.get_pose()
    commit = carry_forward(found.pose, scan.pose, now)
    await localization.set_pose(commit)
    quality = await settled_quality(localization)
    if quality >= GOOD_QUALITY:
        return True, await localization.get_pose(), f"localized (quality {quality})"
    current = await localization.get_pose()
    await localization.set_pose(carry_forward(before, commit, current))
    return False, await localization.get_pose(), (
        f"localization did not converge (quality {quality} < {GOOD_QUALITY}); the previous "
        "pose was restored")

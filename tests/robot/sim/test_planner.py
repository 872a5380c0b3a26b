import numpy as np
import pytest

from hitrobot_server.robot.model import Line, Point2D, Rect
from hitrobot_server.robot.planning.costmap import CostmapConfig, build_costmap, densify
from hitrobot_server.robot.planning.planner import PathSearch, TrackMode, plan
from hitrobot_server.robot.planning.regions import label_regions

START = (5.0, 8.0)


def _costmap(world, **extras):
    return build_costmap(world.spec, world.occupied, world.unknown, CostmapConfig(), **extras)


def _wall(x0, y0, x1, y1, lid=1):
    return Line(lid, Point2D(x0, y0), Point2D(x1, y1))


def _crosses_x(path, x, y_lo, y_hi):
    pts = densify(np.asarray(path), 0.02)
    near = np.abs(pts[:, 0] - x) < 0.02
    return bool(((pts[near, 1] > y_lo) & (pts[near, 1] < y_hi)).any())


def test_paths_keep_the_robot_clear_of_walls(world):
    costmap = _costmap(world)
    result = plan(costmap, START, (21.0, 10.3))  # into the meeting room, through its door
    assert result.ok
    samples = densify(np.asarray(result.path), 0.02)
    ix, iy = world.spec.cells(samples[:, 0], samples[:, 1])
    assert world.free[iy, ix].all()
    assert not costmap.lethal_at(samples[1:]).any()
    assert result.path[0] == START and result.path[-1] == (21.0, 10.3)


def test_virtual_wall_across_the_corridor_is_driven_around(world):
    direct = plan(_costmap(world), START, (20.0, 8.0))
    assert direct.ok and _crosses_x(direct.path, 12.0, 6.9, 9.1)
    walled = plan(_costmap(world, walls=[_wall(12.0, 6.9, 12.0, 9.1)]), START, (20.0, 8.0))
    assert walled.ok
    assert not _crosses_x(walled.path, 12.0, 6.9, 9.1)
    assert min(y for _, y in walled.path) < 6.85  # detour through the open-plan office


def test_no_way_around_fails_with_a_reason(world):
    walls = [_wall(12.0, 0.1, 12.0, 9.1)]  # corridor and open plan both cut
    result = plan(_costmap(world, walls=walls), START, (20.0, 8.0))
    assert not result.ok
    assert result.reason == "no path to the target"


def test_a_goal_in_another_region_fails_after_one_slice(world):
    """The costmap's regions answer what a failed search used to explore the map for."""
    walls = [_wall(12.0, 0.1, 12.0, 9.1)]
    search = PathSearch(_costmap(world, walls=walls), START, (20.0, 8.0))
    assert search.advance(100) is None and search.expansions == 100
    result = search.advance(100)
    assert result is not None and result.reason == "no path to the target"
    assert search.expansions == 100  # the regions told, not a search of the map
    joined = PathSearch(_costmap(world), START, (20.0, 8.0))
    assert joined.advance(100) is None and joined.advance(100) is None  # one region: it runs
    assert joined.expansions == 200


def test_regions_join_cells_through_their_sides_only():
    free = np.array([[1, 1, 0, 1],
                     [0, 1, 0, 1],
                     [1, 0, 1, 1],
                     [1, 0, 0, 0]], dtype=bool)
    labels = label_regions(free)
    assert (labels == 0).tolist() == (~free).tolist()
    groups = {}
    for (row, col), value in np.ndenumerate(labels):
        if value:
            groups.setdefault(int(value), set()).add((row, col))
    assert sorted(map(sorted, groups.values())) == sorted(map(sorted, [
        {(0, 0), (0, 1), (1, 1)}, {(0, 3), (1, 3), (2, 3), (2, 2)}, {(2, 0), (3, 0)}]))


def test_blocked_area_acts_like_an_obstacle(world):
    blocked = [[Point2D(11.0, 6.5), Point2D(12.0, 6.5), Point2D(12.0, 9.5), Point2D(11.0, 9.5)]]
    result = plan(_costmap(world, blocked=blocked), START, (20.0, 8.0))
    assert result.ok and not _crosses_x(result.path, 11.5, 6.5, 9.5)


def test_occupied_goal_is_replaced_unless_told_otherwise(world):
    costmap = _costmap(world)
    inside_desk = (9.75, 2.2)
    result = plan(costmap, START, inside_desk)
    assert result.ok and result.goal != inside_desk
    assert np.hypot(result.goal[0] - 9.75, result.goal[1] - 2.2) < 1.5
    # the replacement is a spot to park on, clear of the inflated zone, not its edge
    col, row = costmap.spec.cell(*result.goal)
    assert costmap.parkable[row, col]
    assert not costmap.lethal_at(np.array([result.goal]) + [[0.08, 0.0]]).any()
    strict = plan(costmap, START, inside_desk, substitute_goal=False)
    assert not strict.ok and "occupied" in strict.reason


def test_bounding_box_restricts_the_search(world):
    costmap = _costmap(world)
    box = Rect(3.0, 6.5, 10.0, 3.0)
    inside = plan(costmap, START, (12.0, 8.0), bbox=box)
    assert inside.ok
    assert all(
        box.x <= x <= box.x + box.width and box.y <= y <= box.y + 3.0 for x, y in inside.path
    )
    outside = plan(costmap, START, (20.0, 12.0), bbox=box, substitute_goal=False)
    assert not outside.ok


def test_smoothing_shortens_the_grid_path(world):
    costmap = _costmap(world)
    raw = plan(costmap, START, (16.0, 3.5), smooth=False)
    smooth = plan(costmap, START, (16.0, 3.5))
    assert raw.ok and smooth.ok
    assert len(smooth.path) < len(raw.path) / 10

    def length(path):
        return float(np.hypot(*np.diff(np.asarray(path), axis=0).T).sum())

    assert length(smooth.path) <= length(raw.path) + 1e-9


def test_strict_track_mode_follows_the_track(world):
    # A track along the corridor's south side; without it the path would hug the centre line.
    tracks = [_wall(4.0, 7.5, 20.0, 7.5)]
    costmap = _costmap(world, tracks=tracks)
    result = plan(costmap, (4.5, 8.2), (19.5, 8.2), track_mode=TrackMode.STRICT)
    assert result.ok
    ys = densify(np.asarray(result.path), 0.05)[:, 1]
    assert np.mean(np.abs(ys - 7.5) < 0.1) > 0.85
    no_tracks = plan(_costmap(world), START, (19.5, 8.2), track_mode=TrackMode.STRICT)
    assert not no_tracks.ok and "track" in no_tracks.reason


def test_priority_track_mode_prefers_the_track(world):
    tracks = [_wall(4.0, 7.5, 20.0, 7.5)]
    costmap = _costmap(world, tracks=tracks)
    free = plan(costmap, (4.5, 8.2), (19.5, 8.2))
    priority = plan(costmap, (4.5, 8.2), (19.5, 8.2), track_mode=TrackMode.PRIORITY)
    assert free.ok and priority.ok

    def on_track(path):
        ys = densify(np.asarray(path), 0.05)[:, 1]
        return float(np.mean(np.abs(ys - 7.5) < 0.1))

    assert on_track(priority.path) > 0.8 > on_track(free.path)


def test_search_can_be_sliced(world):
    costmap = _costmap(world)
    search = PathSearch(costmap, START, (21.0, 10.3))
    slices = 0
    while (result := search.advance(200)) is None:
        slices += 1
        assert slices < 10_000
    assert slices > 1
    assert result.path == plan(costmap, START, (21.0, 10.3)).path


def test_start_inside_an_obstacle_fails(world):
    result = plan(_costmap(world), (9.75, 2.2), START)
    assert not result.ok and result.reason == "the robot is inside an obstacle"


@pytest.mark.parametrize("goal", [(3.5, 0.55), (22.0, 13.5)])
def test_reachable_goals_across_the_office(world, goal):
    assert plan(_costmap(world), START, goal).ok

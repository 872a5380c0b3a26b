"""Sections moved from one state folder into another (``state/moving.py``): real stores on
disk, read back from their files; the move is one journal line in the target, the source gives
its copies up only after it, and a move cut short between the two is finished."""

from __future__ import annotations

import pytest

from hitrobot_server.state import StateStore, StateWriteError
from hitrobot_server.state.journal import decode_journal
from hitrobot_server.state.loading import JOURNAL
from hitrobot_server.state.moving import finish_move, move_sections, moving_from
from tests.state.failing_folder import FailingFolder

MARK = "site/moved"
POIS = [{"type": 100, "name": "kitchen"}]
MASKS = b"\x93NUMPY masks as bytes"


async def robot_folder(path) -> StateStore:
    store = StateStore.open(path)
    for key, value in (("map_manager/pois", POIS), ("map_manager/masks", MASKS),
                       ("map_manager/loaded", "floor1"), ("sim/pose", [1.0, 2.0, 0.0])):
        await store.put(key, value)
    return store


def journal_records(path) -> list[dict]:
    return [changes for _, changes in decode_journal((path / JOURNAL).read_bytes(),
                                                     None).records]


async def test_the_sections_move_in_one_line_and_leave_the_source(tmp_path):
    source = await robot_folder(tmp_path / "robot")
    target = StateStore.open(tmp_path / "site")
    await target.put("fleet/zones", [{"name": "door"}])
    try:
        moved = await move_sections(source, target, "map_manager/", MARK)
    finally:
        await source.close()
        await target.close()
    assert sorted(moved) == ["map_manager/loaded", "map_manager/masks", "map_manager/pois"]
    first, *rest = journal_records(tmp_path / "site")[1:]  # after the zone's line
    assert set(first) == {*moved, MARK} and first[MARK]["cleared"] is False
    assert rest == [{MARK: {"from": "robot", "sections": moved, "cleared": True}}]
    site, robot = StateStore.open(tmp_path / "site"), StateStore.open(tmp_path / "robot")
    try:
        assert site.get("map_manager/pois") == POIS and site.get("map_manager/masks") == MASKS
        assert site.get("map_manager/loaded") == "floor1"
        assert site.get("fleet/zones") == [{"name": "door"}] and moving_from(site, MARK) is None
        assert robot.keys("map_manager/") == [] and robot.get("sim/pose") == [1.0, 2.0, 0.0]
    finally:
        await site.close()
        await robot.close()


async def test_a_section_the_target_has_keeps_the_targets_value(tmp_path):
    source = await robot_folder(tmp_path / "robot")
    target = StateStore.open(tmp_path / "site")
    await target.put("map_manager/pois", [{"type": 100, "name": "newer"}])
    try:
        moved = await move_sections(source, target, "map_manager/", MARK)
        assert "map_manager/pois" not in moved
        assert target.get("map_manager/pois") == [{"type": 100, "name": "newer"}]
        assert source.get("map_manager/pois") == POIS  # not moved: left where it was
    finally:
        await source.close()
        await target.close()


@pytest.mark.parametrize("cleared_source", [False, True])
async def test_a_move_cut_short_is_finished(tmp_path, cleared_source):
    """A crash after the target's line (the source still has its copies), or after the
    source gave them up but before the mark said so: finishing clears and marks."""
    source = await robot_folder(tmp_path / "robot")
    target = StateStore.open(tmp_path / "site")
    names = source.keys("map_manager/")
    try:
        for key in names:
            await target.put(key, source.get(key))
            if cleared_source:
                await source.put(key, None)
        await target.put(MARK, {"from": "robot", "sections": names, "cleared": False})
        assert moving_from(target, MARK) == "robot"
        await finish_move(source, target, MARK)
        assert source.keys("map_manager/") == [] and moving_from(target, MARK) is None
        assert target.get("map_manager/pois") == POIS
        writes = source.writes
        await finish_move(source, target, MARK)  # finished: nothing more
        assert source.writes == writes
    finally:
        await source.close()
        await target.close()


async def test_a_target_that_cannot_be_written_leaves_the_source_whole(tmp_path):
    folder = FailingFolder(tmp_path / "root")
    try:
        source = await robot_folder(tmp_path / "robot")
        target = StateStore.open(folder.root / "site")
        folder.fail(folder.root / "site")
        try:
            with pytest.raises(StateWriteError, match=folder.reason):
                await move_sections(source, target, "map_manager/", MARK)
            assert target.get(MARK) is None and target.keys("map_manager/") == []
        finally:
            await source.close()
            await target.close()
        robot = StateStore.open(tmp_path / "robot")
        try:
            assert robot.get("map_manager/pois") == POIS
            assert robot.get("map_manager/masks") == MASKS
        finally:
            await robot.close()
    finally:
        folder.close()

"""What counts as an incident (record/incidents.py) on a real bus, fed the messages the nodes
publish, and the debounce of BlackBoxControl: one incident makes one file."""

from __future__ import annotations

import asyncio
import os

import pytest

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.errors import ServiceError
from hitrobot_server.record.blackbox_control import BlackBoxControl
from hitrobot_server.record.blackbox_file import read_incident
from hitrobot_server.record.incidents import MAX_NAMES, IncidentWatch
from hitrobot_server.types.registry import TypeRegistry

DIAG = "/diagnostics"
STATE = "/slamware_ros_sdk_server_node/state"
NAV = "/navigate_to_pose/_action/status"


def watched_bus(threshold: int = 30) -> tuple[Bus, list[tuple[str, str]]]:
    bus = Bus(TypeRegistry.default())
    reports: list[tuple[str, str]] = []
    bus.taps.append(IncidentWatch(lambda c, d: reports.append((c, d)),
                                  localization_threshold=threshold))
    bus.advertise(DIAG, "diagnostic_msgs/DiagnosticArray", "t", "/t")
    bus.advertise(STATE, "slamware_ros_sdk/RobotBasicState", "t", "/t")
    bus.advertise(NAV, "action_msgs/GoalStatusArray", "t", "/t")
    return bus, reports


def connection(bus: Bus, level: int, text: str, name: str = "/Robot/Connection") -> None:
    bus.publish(DIAG, {"header": {"frame_id": ""}, "status": [
        {"level": 0, "name": "/Bridge/Clients", "message": "", "hardware_id": "", "values": []},
        {"level": level, "name": name, "message": text, "hardware_id": "", "values": []}]})


def quality(bus: Bus, value: int, enabled: bool = True) -> None:
    bus.publish(STATE, {"is_map_building_enabled": False, "is_localization_enabled": enabled,
                        "localization_quality": value, "board_temperature": 30,
                        "battery_percentage": 90, "is_dc_in": False, "is_charging": False})


def goals(bus: Bus, *statuses: tuple[int, int]) -> None:
    bus.publish(NAV, {"status_list": [
        {"goal_info": {"goal_id": {"uuid": [n] * 16}, "stamp": {"sec": 0, "nanosec": 0}},
         "status": status} for n, status in statuses]})


def test_a_link_lost_after_it_was_up_is_one_incident_until_it_comes_back():
    bus, reports = watched_bus()
    connection(bus, 2, "not connected")  # never up: a robot not there yet is no incident
    connection(bus, 0, "connected")
    connection(bus, 2, "not connected")
    connection(bus, 2, "not connected")  # still down: the same incident
    assert reports == [("link_lost", "not connected")]
    connection(bus, 0, "connected")
    connection(bus, 2, "the robot does not answer: timeout", name="/r1/Robot/Connection")
    connection(bus, 0, "connected", name="/r1/Robot/Connection")
    connection(bus, 2, "the robot does not answer: timeout", name="/r1/Robot/Connection")
    assert reports[1:] == [("link_lost", "r1: the robot does not answer: timeout")]


def health(bus: Bus, level: int, text: str) -> None:
    bus.publish(DIAG, {"header": {"frame_id": ""}, "status": [
        {"level": level, "name": "/Robot/Health", "message": text, "hardware_id": "",
         "values": []}]})


def test_an_emergency_stop_pressed_is_one_incident_until_it_is_released():
    """As the simulator's /sim/emergency_stop shows on the diagnostics: a FATAL health
    error "emergency stop pressed" (the Robot/Health item turns ERROR)."""
    bus, reports = watched_bus()
    health(bus, 0, "no errors")
    health(bus, 2, "left wheel overcurrent")  # an error, not a stop
    health(bus, 2, "left wheel overcurrent; emergency stop pressed")
    health(bus, 2, "emergency stop pressed")  # still pressed
    health(bus, 0, "no errors")  # released
    health(bus, 2, "Emergency stop pressed")
    assert reports == [("emergency_stop", "left wheel overcurrent; emergency stop pressed"),
                       ("emergency_stop", "Emergency stop pressed")]


def test_localization_under_its_threshold_is_an_incident_with_hysteresis():
    bus, reports = watched_bus(threshold=30)
    quality(bus, 10)  # never localized yet (starting up): no incident
    quality(bus, 80)
    quality(bus, 20)
    quality(bus, 5)
    quality(bus, 35)  # over the threshold, not by the hysteresis: still lost
    quality(bus, 25)
    assert reports == [("localization_lost", f"{STATE}: localization quality 20 < 30")]
    quality(bus, 90)
    quality(bus, 0, enabled=False)  # localization switched off: not a loss
    quality(bus, 29)
    assert [c for c, _d in reports] == ["localization_lost"] * 2


def test_a_ros2_goal_turning_aborted_is_one_incident_however_often_it_is_listed():
    bus, reports = watched_bus()
    goals(bus, (1, 2))
    goals(bus, (1, 6), (2, 2))
    goals(bus, (1, 6), (2, 4))  # the first listed again; the second succeeded
    goals(bus, (1, 6), (2, 4), (3, 6))
    assert reports == [("goal_aborted", "/navigate_to_pose: goal 01010101 aborted"),
                       ("goal_aborted", "/navigate_to_pose: goal 03030303 aborted")]


def test_a_threshold_of_zero_never_reports_localization():
    bus, reports = watched_bus(0)
    quality(bus, 80)
    quality(bus, 0)
    assert reports == []


async def test_one_incident_makes_one_file(tmp_path):
    """The link lost, then the goal it aborted, within the gathering second: one file naming
    both; the same cause again at once is the same incident (no second file)."""
    bus = Bus(TypeRegistry.default())
    control = BlackBoxControl(bus, tmp_path, seconds=10.0, max_bytes=1 << 20)
    await control.start()
    written: asyncio.Queue = asyncio.Queue()
    bus.subscribe("/record/incident", None, "test", "/test", lambda m: written.put_nowait(m.msg))
    try:
        bus.advertise(DIAG, "diagnostic_msgs/DiagnosticArray", "t", "/t")
        bus.advertise("/move_base/result", "move_base_msgs/MoveBaseActionResult", "t", "/t")
        assert (await asyncio.wait_for(written.get(), 1))["cause"] == ""  # on, none yet
        connection(bus, 0, "connected")
        connection(bus, 2, "not connected")
        bus.publish("/move_base/result", {"status": {"goal_id": {"id": "g1"}, "status": 4,
                                                     "text": "the robot is not connected"}})
        first = await asyncio.wait_for(written.get(), 60)  # the writer process starts
        assert first["cause"] == "link_lost" and first["count"] == 1
        assert first["detail"] == ("not connected; goal_aborted: /move_base: goal "
                                   "'g1' aborted: the robot is not connected")
        incident = read_incident(tmp_path / first["file"])
        assert incident is not None and incident.cause == "link_lost"
        assert incident.detail == first["detail"]

        connection(bus, 0, "connected")
        connection(bus, 2, "not connected")  # flapping: the same incident
        assert control.suppressed == 1
        assert sorted(p.name for p in tmp_path.iterdir()) == [first["file"]]
    finally:
        await control.stop()
    shutdown = await asyncio.wait_for(written.get(), 60)  # the writer process starts
    assert shutdown["cause"] == "shutdown" and shutdown["count"] == 2
    assert len(list(tmp_path.glob("blackbox-*.mcap"))) == 2


async def test_a_snapshot_that_cannot_be_written_says_so(tmp_path):
    """The recordings folder is a file: the snapshot fails with the reason, the incident topic
    names no file, and the black box goes on (a later snapshot to a good folder works)."""
    bus = Bus(TypeRegistry.default())
    blocked = tmp_path / "not-a-folder"
    blocked.write_text("")
    control = BlackBoxControl(bus, blocked, seconds=10.0, max_bytes=1 << 20)
    await control.start()
    written: asyncio.Queue = asyncio.Queue()
    bus.subscribe("/record/incident", None, "test", "/test", lambda m: written.put_nowait(m.msg))
    try:
        assert (await asyncio.wait_for(written.get(), 1))["cause"] == ""
        with pytest.raises(ServiceError, match="the black box could not be written"):
            await bus.call_service("/record/snapshot", {"reason": "r"}, timeout=60)
        failed = await asyncio.wait_for(written.get(), 1)
        assert failed["cause"] == "snapshot" and failed["file"] == "" and failed["count"] == 0
        control.folder = tmp_path / "recordings"
        reply = await bus.call_service("/record/snapshot", {"reason": "again"}, timeout=60)
        assert reply["success"] and (control.folder / reply["path"]).is_file()
    finally:
        await control.stop()


def test_the_watch_keeps_a_bounded_set_of_item_names():
    bus, reports = watched_bus()
    for i in range(MAX_NAMES + 500):  # a node's ever new items: the oldest are forgotten
        connection(bus, 0, "connected", name=f"/r{i}/Robot/Connection")
    watch = next(t for t in bus.taps if isinstance(t, IncidentWatch))
    assert len(watch._connected) == MAX_NAMES and reports == []


def old_black_box_files(folder, count: int, size: int) -> list:
    """``count`` black-box files of ``size`` bytes, an hour apart, the oldest first."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(count):
        path = folder / f"blackbox-2026010{i}-000000-snapshot.mcap"
        path.write_bytes(b"\0" * size)
        os.utime(path, (1_700_000_000 + 3600 * i,) * 2)
        paths.append(path)
    return paths


async def test_the_black_box_files_keep_a_disk_budget_oldest_first(tmp_path):
    bus = Bus(TypeRegistry.default())
    mb = 1024 * 1024
    old = old_black_box_files(tmp_path, 5, mb)
    (tmp_path / "recording.mcap").write_bytes(b"\0" * mb)  # not the black box's: kept
    control = BlackBoxControl(bus, tmp_path, seconds=10.0, max_bytes=mb,
                              disk_bytes=4 * mb + mb // 2)
    await control.start()
    try:  # the next file may take a little over 1 MiB: 3 MiB of old ones stay, oldest go first
        reply = await bus.call_service("/record/snapshot", {"reason": "r"}, timeout=60)
        assert reply["success"]
        assert [p.exists() for p in old] == [False, False, True, True, True]
        assert (tmp_path / "recording.mcap").exists() and (tmp_path / reply["path"]).exists()
    finally:
        await control.stop()


async def test_a_black_box_file_keeps_the_free_space_reserve(tmp_path):
    bus = Bus(TypeRegistry.default())
    vfs = os.statvfs(tmp_path)
    control = BlackBoxControl(bus, tmp_path, seconds=10.0, max_bytes=1 << 20,
                              reserve=vfs.f_bavail * vfs.f_frsize)  # more than will be free
    await control.start()
    try:
        with pytest.raises(ServiceError, match="MiB kept free"):
            await bus.call_service("/record/snapshot", {"reason": "r"}, timeout=60)
        assert list(tmp_path.glob("blackbox-*.mcap")) == []
    finally:
        control.reserve = 0  # the shutdown file
        await control.stop()


async def test_snapshots_asked_for_at_once_share_one_file(tmp_path):
    bus = Bus(TypeRegistry.default())
    control = BlackBoxControl(bus, tmp_path, seconds=10.0, max_bytes=1 << 20)
    await control.start()
    try:
        replies = await asyncio.gather(*(bus.call_service(
            "/record/snapshot", {"reason": f"r{i}"}, timeout=60) for i in range(100)))
        assert all(r["success"] for r in replies)
        names = {r["path"] for r in replies}
        assert len(names) == 1 and (tmp_path / names.pop()).is_file()
    finally:
        await control.stop()

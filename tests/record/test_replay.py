"""``hitrobot-server replay``: a recording served to roslibpy and roslibjs with its recorded
poses and stamps, the latched map for late joiners, seek/pause/speed; bad files refused."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import roslibpy
from mcap.reader import make_reader
from mcap.writer import Writer
from mcap_ros2.decoder import DecoderFactory

from tests.clients.test_roslibjs import run_checks
from tests.helpers import ServerProcess, connect_roslibpy
from tests.record.conftest import ODOM

JS = Path(__file__).resolve().parents[1] / "js"


def stamp_key(stamp) -> tuple[int, int]:
    if isinstance(stamp, dict):
        return stamp["secs"], stamp["nsecs"]
    return stamp.sec, stamp.nanosec


@pytest.fixture(scope="module")
def recorded(drive):
    """The recorded odometry (stamp → x, y) and map size, read with mcap-ros2-support."""
    path, _live = drive
    poses, grid = {}, None
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _s, channel, _m, msg in reader.iter_decoded_messages(topics=[ODOM, "/map"]):
            if channel.topic == ODOM:
                p = msg.pose.pose.position
                poses[stamp_key(msg.header.stamp)] = (p.x, p.y)
            else:
                grid = (msg.info.width, msg.info.height)
    return poses, grid


@pytest.fixture(scope="module")
def replay(drive):
    path, _live = drive
    server = ServerProcess("--loop", command=("replay", str(path)))
    yield server
    server.stop()


class Collector:
    """Messages of one topic, with a bounded wait for the n-th."""

    def __init__(self, ros, topic: str, type_name: str):
        self.items: list[dict] = []
        self._cond = threading.Condition()
        self.topic = roslibpy.Topic(ros, topic, type_name)
        self.topic.subscribe(self._add)

    def _add(self, msg: dict) -> None:
        with self._cond:
            self.items.append(msg)
            self._cond.notify_all()

    def wait_for(self, predicate, what: str, timeout: float = 15.0) -> dict:
        with self._cond:
            assert self._cond.wait_for(lambda: any(map(predicate, self.items)), timeout), what
            return next(m for m in reversed(self.items) if predicate(m))

    def count(self, n: int, timeout: float = 15.0) -> list[dict]:
        with self._cond:
            assert self._cond.wait_for(lambda: len(self.items) >= n, timeout), f"{n} messages"
            return list(self.items)


def call(ros, name: str, type_name: str, args: dict | None = None) -> dict:
    return roslibpy.Service(ros, name, type_name).call(roslibpy.ServiceRequest(args or {}),
                                                      timeout=10)


def test_replay_serves_the_recorded_poses_and_the_latched_map(replay, recorded):
    poses, grid = recorded
    ros = connect_roslibpy(replay.port)
    try:
        odom = Collector(ros, ODOM, "nav_msgs/Odometry")
        got = odom.count(20)
        keys = [stamp_key(m["header"]["stamp"]) for m in got]
        for msg, key in zip(got, keys, strict=True):
            position = msg["pose"]["pose"]["position"]
            assert poses[key] == (position["x"], position["y"])
        assert sum(b < a for a, b in zip(keys, keys[1:], strict=False)) <= 1  # a loop at most
        late = Collector(ros, "/map", "nav_msgs/OccupancyGrid").count(1)[0]
        assert (late["info"]["width"], late["info"]["height"]) == grid
        assert len(late["data"]) == grid[0] * grid[1]
    finally:
        ros.close()


def test_pause_seek_and_speed(replay, recorded):
    poses, _grid = recorded
    first = min(poses)
    ros = connect_roslibpy(replay.port)
    try:
        state = Collector(ros, "/replay/state", "hitrobot_msgs/ReplayState")
        assert call(ros, "/replay/pause", "std_srvs/Trigger")["success"]
        state.wait_for(lambda s: s["paused"], "paused")
        reply = call(ros, "/replay/seek", "hitrobot_msgs/ReplaySeek", {"position": 2.0})
        assert reply["success"], reply
        state.wait_for(lambda s: s["paused"] and s["position"] == 2.0, "at 2 s, paused")
        assert call(ros, "/replay/set_speed", "hitrobot_msgs/ReplaySetSpeed",
                    {"speed": 2.0})["success"]
        still = state.wait_for(lambda s: s["speed"] == 2.0, "speed 2")
        assert still["paused"] and still["position"] == 2.0  # paused: it did not move
        odom = Collector(ros, ODOM, "nav_msgs/Odometry")
        assert call(ros, "/replay/resume", "std_srvs/Trigger")["success"]
        msg = odom.count(1)[0]
        secs, nsecs = stamp_key(msg["header"]["stamp"])
        offset = secs + nsecs / 1e9 - (first[0] + first[1] / 1e9)
        assert 1.8 <= offset <= 2.6, offset
        for name, type_name, bad, field in (
                ("/replay/seek", "hitrobot_msgs/ReplaySeek", {"position": -1.0}, "position"),
                ("/replay/seek", "hitrobot_msgs/ReplaySeek", {"position": 1e9}, "position"),
                ("/replay/set_speed", "hitrobot_msgs/ReplaySetSpeed", {"speed": 0.0}, "speed")):
            with pytest.raises(roslibpy.core.ServiceException, match=f"field '{field}'"):
                call(ros, name, type_name, bad)
        latest = state.items[-1]
        assert not latest["paused"] and latest["speed"] == 2.0  # the refusals changed nothing
    finally:
        ros.close()


async def test_replay_to_roslibjs(replay, recorded, tmp_path):
    if not (JS / "node_modules" / "roslib").is_dir():
        raise RuntimeError("roslibjs is not installed: run `npm ci --prefix tests/js`")
    poses, grid = recorded
    table = tmp_path / "poses.json"
    table.write_text(json.dumps({"poses": {f"{s}.{n}": p for (s, n), p in poses.items()},
                                 "grid": grid}))
    await run_checks(JS / "roslibjs_replay.mjs", replay.port,
                     ["recorded_poses", "latched_map_late_joiner", "seek_and_state"], 60,
                     extra=[str(table)])


def alien_file(path: Path, schema_name: str, text: str, encoding: str = "ros2msg") -> Path:
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(schema_name, encoding, text.encode())
        channel = writer.register_channel("/chatter", "cdr", schema)
        writer.add_message(channel, 1, b"\x00\x01\x00\x00\x01\x00\x00\x00\x00", 1)
        writer.finish()
    return path


def replay_exit(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "hitrobot_server", "replay", str(path), "--port", "0",
         "--tcp-port", "0"], capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("case", ["not_mcap", "truncated", "not_ros2", "unparsable",
                                  "missing"])
def test_bad_files_are_refused_with_a_clear_error(case, drive, tmp_path):
    path, _live = drive
    target = tmp_path / f"{case}.mcap"
    if case == "not_mcap":
        target.write_text("just text\n")
        expected = "is not an MCAP file"
    elif case == "truncated":  # cut before its first message (a later cut plays: see
        target.write_bytes(path.read_bytes()[:300])  # test_replay_files)
        expected = "cut off before any"
    elif case == "not_ros2":
        alien_file(target, "std_msgs/msg/String", "{}", encoding="jsonschema")
        expected = "is not ROS 2"
    elif case == "unparsable":
        alien_file(target, "foo_msgs/msg/Bar", "int32 data\nfoo_msgs/Missing m\n")
        expected = "refers to foo_msgs/msg/Missing"
    else:
        expected = "cannot open"
    done = replay_exit(target)
    assert done.returncode != 0
    assert expected in done.stderr, done.stderr
    assert "ws://" not in done.stdout


def test_a_replay_file_of_our_own_type_with_the_same_fields_plays(tmp_path):
    """A schema written by another tool (comments, other spacing) is accepted by its fields."""
    target = alien_file(tmp_path / "ok.mcap", "std_msgs/msg/String",
                        "# a comment\nstring   data  # the text\n")
    server = ServerProcess(command=("replay", str(target)))
    try:
        ros = connect_roslibpy(server.port)
        state = Collector(ros, "/replay/state", "hitrobot_msgs/ReplayState")
        assert state.count(1)[0]["file"] == "ok.mcap"
        ros.close()
    finally:
        server.stop()


async def test_replay_speed_out_of_range_exits_non_zero(drive):
    path, _live = drive
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "hitrobot_server", "replay", str(path), "--speed", "0",
        "--port", "0", "--tcp-port", "0", stderr=asyncio.subprocess.PIPE)
    _out, err = await asyncio.wait_for(proc.communicate(), 60)
    assert proc.returncode != 0 and b"--speed" in err


def test_replay_refuses_a_robot_too(drive):
    path, _live = drive
    done = subprocess.run(
        [sys.executable, "-m", "hitrobot_server", "replay", str(path), "--robot", "sim",
         "--port", "0", "--tcp-port", "0"], capture_output=True, text=True, timeout=60)
    assert done.returncode != 0 and "--robot cannot be used" in done.stderr

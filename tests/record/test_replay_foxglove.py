"""Foxglove's timeline drives a replay: a raw Foxglove WebSocket client (binary frames as the
protocol lays them out) sees the data's range in ``serverInfo``, plays from a seek at a speed,
pauses, and follows the recording's time in the ``time`` messages."""

from __future__ import annotations

import asyncio
import json
import struct

import pytest
from websockets.asyncio.client import connect

from hitrobot_server.protocol import foxglove_playback as pb
from tests.helpers import ServerProcess

TIME_OP = 2


@pytest.fixture(scope="module")
def replay(drive):
    path, _live = drive
    server = ServerProcess(command=("replay", str(path)))
    yield server
    server.stop()


class Frames:
    """A Foxglove client's frames, read until one matches (bounded in count and time)."""

    def __init__(self, ws):
        self.ws = ws

    async def next(self, predicate, what: str, limit: int = 400, timeout: float = 15.0):
        async def read():
            for _ in range(limit):
                frame = await self.ws.recv()
                if predicate(frame):
                    return frame
            raise AssertionError(f"{what}: not among {limit} frames")
        return await asyncio.wait_for(read(), timeout)

    async def info(self) -> dict:
        return json.loads(await self.next(lambda f: isinstance(f, str) and '"serverInfo"' in f,
                                          "serverInfo"))

    async def time(self) -> int:
        frame = await self.next(lambda f: isinstance(f, bytes) and f[0] == TIME_OP, "time")
        return struct.unpack_from("<Q", frame, 1)[0]

    async def state(self, request_id: str | None = None) -> tuple[int, int, float, bool, str]:
        frame = await self.next(
            lambda f: isinstance(f, bytes) and f[0] == pb.SERVER_PLAYBACK_STATE and (
                request_id is None or pb.parse_state(f)[4] == request_id), "playback state")
        return pb.parse_state(frame)

    async def status(self) -> dict:
        return json.loads(await self.next(lambda f: isinstance(f, str) and '"status"' in f,
                                          "status"))


def ns(stamp: dict) -> int:
    return stamp["sec"] * 10**9 + stamp["nsec"]


async def test_the_timeline_plays_seeks_pauses_and_sets_the_speed(replay, drive):
    async with connect(f"ws://127.0.0.1:{replay.port}",
                       subprotocols=["foxglove.websocket.v1"]) as ws:
        frames = Frames(ws)
        info = await frames.info()
        assert pb.CAPABILITY in info["capabilities"] and "time" in info["capabilities"]
        start, end = ns(info["dataStartTime"]), ns(info["dataEndTime"])
        assert 7e9 < end - start < 60e9  # the 8 s drive, and the server starting before it
        assert await frames.time() == start  # paused at its start: the clock is the recording's

        seek = start + 2 * 10**9
        await ws.send(pb.request_frame(True, 2.0, seek, "r1"))
        status, current, speed, did_seek, _rid = await frames.state("r1")
        assert (status, speed, did_seek) == (pb.PLAYING, 2.0, True)
        assert seek <= current < seek + 5 * 10**8
        later = await frames.next(lambda f: isinstance(f, bytes) and f[0] == TIME_OP and (
            struct.unpack_from("<Q", f, 1)[0] > seek + 10**8), "the clock moving on")
        assert struct.unpack_from("<Q", later, 1)[0] <= end

        await ws.send(pb.request_frame(False, 2.0, None, "r2"))
        status, paused_at, _speed, did_seek, _rid = await frames.state("r2")
        assert status == pb.PAUSED and not did_seek
        assert [await frames.time() for _ in range(3)] == [paused_at] * 3  # the clock stopped

        await ws.send(b"\x03\x07" + bytes(17))  # command 7: neither play nor pause
        assert "playbackCommand" in (await frames.status())["message"]
        await ws.send(pb.request_frame(True, 2.0, end, "r3"))  # to the end: it ends
        assert (await frames.state("r3"))[0] in (pb.PLAYING, pb.ENDED)
        assert (await frames.state())[0] == pb.ENDED


async def test_a_server_that_does_not_replay_has_no_timeline(server):
    async with connect(f"ws://127.0.0.1:{server.port}",
                       subprotocols=["foxglove.websocket.v1"]) as ws:
        frames = Frames(ws)
        info = await frames.info()
        assert pb.CAPABILITY not in info["capabilities"] and "dataStartTime" not in info
        await ws.send(pb.request_frame(True, 1.0, None, "x"))
        assert "not replaying" in (await frames.status())["message"]

"""How far a request travels through our code: files and calls on the way, counted.

The issue that asked for shorter walks (issue 32) followed four journeys as a newcomer would:

1. ``rosbridge publish``: a ``publish`` frame of one client to the bytes another client's
   outbox hands its transport (two sessions on a bare bus, as the transports drive them);
2. ``foxglove subscribe /scan``: a Foxglove client's ``subscribe`` frame for the ``/scan``
   channel, then one ``/scan`` message published on the bus right after it (the simulated
   robot's own scan, published again by the bench), to the message data frame in the client's
   outbox: the subscribe and the first delivery, as one walk;
3. ``fleet dispatch``: a rosbridge ``call_service`` of ``/fleet/dispatch`` to a POI, on a server
   with two simulated named robots, to the ``service_response`` in the client's outbox (the POI
   read, both robots' path plans, the task started);
4. ``poi durable``: a rosbridge ``publish`` on ``/map_manager/add_poi`` to the ``status`` that
   acknowledges it, which the map manager sends only once the state store has fsynced it: the
   store's writer thread is profiled too and its calls counted in the same walk.

``call_service`` (a client's call of a service in the bench, to its reply) is printed too, as
before. Each line reads ``NAME: F files, N functions, C calls``, then the functions entered per
file. Fewer is a shorter walk for a reader, not a speed claim (``bench_bridge.py`` measures
speed).

How the counts stay the journey's and stay the same from run to run:

* every call into ``hitrobot_server`` is counted (a coroutine resumed counts as a call, as the
  profiler sees it) with ``sys.setprofile`` on the event loop's thread and
  ``threading.setprofile`` on every thread started after the bench began (the worker threads of
  ``asyncio.to_thread``), only while a walk is measured;
* while a walk runs the event loop's clock is held still, so no timer fires: the simulator's
  ticks and the nodes' periodic publishes (a few thousand calls a second) stay out of the
  window, and what is counted is the journey and what it sets off. Before the window the loop
  settles (threads' work in flight ends, ready callbacks run); a walk that waits on a timer
  would hang, so the clock runs again after :data:`HOLD_LIMIT` seconds and the walk fails;
* each journey runs in a fresh world (server, clients), first once unmeasured (first-use
  caches warm), then measured; that is done :data:`RUNS` times and the last run is printed, with
  a note when the runs differ. Servers use temporary folders and loopback only.

The construction of each world is one small function (``*_world``, ``rosbridge_client``,
``foxglove_client``): the only code to adapt when the server's insides move.

    .venv/bin/python bench/bench_walk.py
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path
from typing import Any, TypeVar

import hitrobot_server
from hitrobot_server.bus.core import Bus
from hitrobot_server.config import Settings
from hitrobot_server.nodes.base import Node
from hitrobot_server.robot.options import RobotEntry
from hitrobot_server.server import HitrobotServer
from hitrobot_server.session.options import SessionOptions
from hitrobot_server.session.rosbridge.session import Session, Shared
from hitrobot_server.types.registry import TypeRegistry

PACKAGE = str(Path(hitrobot_server.__file__).parent)
TOPIC = "/walk/chatter"
RUNS = 2
HOLD_LIMIT = 20.0  # s of real time a walk may take with the loop's clock held
SETTLE = 0.05  # s for threads' work in flight to end before a window opens
SETTLE_STEPS = 50  # loop iterations run before a window opens
POI_T = "map_messages/PointOfInterest"
FOXGLOVE_V1 = "foxglove.websocket.v1"  # the subprotocol Foxglove Studio asks for
MESSAGE_DATA = 1  # a Foxglove server's binary opcode: one message of one subscription
CORRIDOR = 8.0  # y of the simulated office's corridor (tests/nodes/fleet/test_node.py)
T = TypeVar("T")
Client = Any  # a rosbridge Session or a FoxgloveSession: frames in, its outbox drained


class Walk:
    """Counts calls into hitrobot_server, per thread, while it is switched on."""

    def __init__(self) -> None:
        self.per_thread: dict[int, Counter[tuple[str, str]]] = {}

    def __call__(self, frame, event, arg) -> None:
        if event == "call" and frame.f_code.co_filename.startswith(PACKAGE):
            calls = self.per_thread.get(threading.get_ident())
            if calls is None:
                calls = self.per_thread[threading.get_ident()] = Counter()
            rel = frame.f_code.co_filename[len(PACKAGE) + 1:]
            calls[(rel, frame.f_code.co_qualname)] += 1

    @property
    def calls(self) -> Counter[tuple[str, str]]:
        return sum(self.per_thread.values(), Counter())

    def figures(self) -> tuple[int, int, int]:
        calls = self.calls
        return len({f for f, _ in calls}), len(calls), sum(calls.values())

    def report(self, name: str, runs: list[tuple[int, int, int]]) -> None:
        files, functions, total = self.figures()
        note = "" if len(set(runs)) == 1 else f"  (runs differ: {runs})"
        print(f"{name}: {files} files, {functions} functions, {total} calls{note}")
        calls = self.calls
        for f in sorted({f for f, _ in calls}):
            names = [q for g, q in calls if g == f]
            print(f"    {f}: {', '.join(sorted(names))}")


class Walker:
    """Measures walks: the profiler on every thread, the loop's clock held during a walk."""

    def __init__(self) -> None:
        self.current: Walk | None = None
        threading.setprofile(self._thread_hook)  # threads started from now on

    def _thread_hook(self, frame, event, arg) -> None:
        walk = self.current
        if walk is not None:
            walk(frame, event, arg)

    async def run(self, journey: Callable[[], Awaitable[T]],
                  after: Callable[[T], Awaitable[object]] | None = None, *,
                  measure: bool = True, quiet: tuple[Client, ...] = ()) -> tuple[Walk, T]:
        """``journey`` with the clock held, counted when ``measure``; first the loop settles
        and the ``quiet`` clients' outboxes are drained, so the window holds the journey
        only. ``after`` runs with the clock still held, not counted: it undoes what the
        journey started before a timer moves it on."""
        walk = Walk()
        async with held_clock():
            await settle()
            for client in quiet:
                await drain(client)
            if measure:
                self.current = walk
                sys.setprofile(walk)
            try:
                result = await journey()
            finally:
                sys.setprofile(None)
                self.current = None
            if after is not None:
                await after(result)
        return walk, result


@contextlib.asynccontextmanager
async def held_clock() -> AsyncIterator[None]:
    """The running loop's clock stands still (no timer fires) until the block ends, or for at
    most :data:`HOLD_LIMIT` s of real time (then the walk is reported as waiting on a timer)."""
    loop = asyncio.get_running_loop()
    real = loop.time
    held_at, since = real(), time.monotonic()
    overdue = False

    def clock() -> float:
        nonlocal overdue
        if time.monotonic() - since < HOLD_LIMIT:
            return held_at
        overdue = True
        return real()

    loop.time = clock  # type: ignore[method-assign]  # the loop's own attribute, for this block
    try:
        yield
    finally:
        del loop.time
    if overdue:
        raise RuntimeError("a walk waited on a timer: its counts would not be the journey's")


async def settle() -> None:
    """Let work in flight end: threads' (a real-time wait in a thread), then the loop's."""
    await asyncio.get_running_loop().run_in_executor(None, time.sleep, SETTLE)
    for _ in range(SETTLE_STEPS):
        await asyncio.sleep(0)


async def send(client: Client, op: dict) -> None:
    """One op as a text frame, handled (a rosbridge session may hand back its handling)."""
    pending = client.receive(json.dumps(op))
    if pending is not None:
        await pending


async def until(client: Client, wanted: Callable[[Any, bool], bool]) -> Any:
    """Drain the client's outbox (as its transport would) until a frame is ``wanted``."""
    while True:
        frames = await client.outbox.get()
        if frames is None:
            raise ConnectionError("the session closed its outbox")
        client.outbox.sent()
        for data, binary in frames:
            if wanted(data, binary):
                return data


async def drain(client: Client) -> None:
    """Everything already queued for the client, without waiting for more."""
    while len(client.outbox):
        await client.outbox.get()
        client.outbox.sent()


def op_is(op: str, **fields: object) -> Callable[[Any, bool], bool]:
    def wanted(data: Any, binary: bool) -> bool:
        if binary:
            return False
        msg = json.loads(data)
        return msg.get("op") == op and all(msg.get(k) == v for k, v in fields.items())
    return wanted


def status_of(what: str) -> Callable[[Any, bool], bool]:
    def wanted(data: Any, binary: bool) -> bool:
        if binary:
            return False
        msg = json.loads(data)
        return msg.get("op") == "status" and f"{what}: " in str(msg.get("msg", ""))
    return wanted


async def request(client: Client, op: dict, wanted: Callable[[Any, bool], bool]) -> Any:
    """One op sent, then its answer drained: the shape of every walk below."""
    await send(client, op)
    return await until(client, wanted)


async def eventually(predicate: Callable[[], bool], what: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise TimeoutError(f"never saw {what} within {timeout} s")
        await asyncio.sleep(0.05)


def pose(x: float, y: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}


# ---------------------------------------------------------------------- worlds (adapt here)
def bare_bus_world() -> tuple[Bus, Session, Session]:
    """Two rosbridge sessions on a bus without nodes."""
    bus = Bus(TypeRegistry.default())
    options = SessionOptions()
    shared = Shared.for_options(options)
    return (bus, Session(bus, options, peer="walk-a", shared=shared),
            Session(bus, options, peer="walk-b", shared=shared))


@contextlib.asynccontextmanager
async def server_world(folder: Path, **settings: Any) -> AsyncIterator[HitrobotServer]:
    """A real assembled server on loopback, every folder it writes in ``folder``."""
    server = HitrobotServer(Settings.of(
        port=0, tcp_port=-1, address="127.0.0.1", unregister_timeout=0.2,
        state_dir=str(folder / "state"), map_dir=str(folder / "maps"),
        record_dir=str(folder / "recordings"), **settings))
    await server.start()
    try:
        yield server
    finally:
        await server.stop()


def single_robot_world(folder: Path) -> contextlib.AbstractAsyncContextManager[HitrobotServer]:
    """The everyday server: one simulated robot, unnamed."""
    return server_world(folder, robot="sim")


def fleet_world(folder: Path) -> contextlib.AbstractAsyncContextManager[HitrobotServer]:
    """Two simulated named robots in the office corridor, 8 m apart."""
    return server_world(folder, robots=(RobotEntry("a", "sim", (4.0, CORRIDOR, 0.0)),
                                        RobotEntry("b", "sim", (12.0, CORRIDOR, 0.0))))


def rosbridge_client(server: HitrobotServer) -> Session:
    """A rosbridge client's session, as the WebSocket transport makes it."""
    return server.new_session("walk", "ws")


def foxglove_client(server: HitrobotServer) -> Any:
    """A Foxglove client's session, as the WebSocket transport makes it."""
    return server.new_foxglove_session("walk", FOXGLOVE_V1)


# ---------------------------------------------------------------------- the journeys
async def rosbridge_publish(walker: Walker, _folder: Path) -> Walk:
    """1. A publish from one client's frame to another client's outbox."""
    _bus, a, b = bare_bus_world()
    try:
        for client, op in ((a, {"op": "advertise", "topic": TOPIC, "type": "std_msgs/String"}),
                           (b, {"op": "subscribe", "topic": TOPIC, "type": "std_msgs/String"})):
            await send(client, op)
        publish = {"op": "publish", "topic": TOPIC, "msg": {"data": "hello"}}

        async def journey() -> Any:
            await send(a, publish)
            return await until(b, anything)

        return await twice(walker, journey, quiet=(a, b))
    finally:
        a.close()
        b.close()


async def call_service(walker: Walker, _folder: Path) -> Walk:
    """A call of a service the bench serves, from the client's frame to its reply."""
    bus, a, b = bare_bus_world()

    async def echo(request: dict) -> dict:
        return {"success": True, "message": "pong"}

    bus.advertise_service("/walk/echo", "std_srvs/Trigger", "walk", "walk", echo)
    call = {"op": "call_service", "id": "c1", "service": "/walk/echo",
            "type": "std_srvs/Trigger", "args": {}}
    try:
        return await twice(walker, lambda: request(a, call, op_is("service_response")),
                           quiet=(a,))
    finally:
        a.close()
        b.close()


async def foxglove_scan(walker: Walker, folder: Path) -> Walk:
    """2. A Foxglove subscribe to /scan, then the first /scan message to its data frame."""
    async with single_robot_world(folder) as server:
        scan = await one_message(server.bus, "/scan", "sensor_msgs/LaserScan")
        lidar = Node(server.bus, "/walk_lidar")  # publishes the robot's scan again, on cue
        lidar.advertise("/scan", "sensor_msgs/LaserScan")
        fox = foxglove_client(server)
        channel = await until(fox, lambda data, binary: not binary and any(
            c["topic"] == "/scan" for c in json.loads(data).get("channels", ())))
        channel_id = next(c["id"] for c in json.loads(channel)["channels"]
                          if c["topic"] == "/scan")
        subscribe = {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": channel_id}]}

        async def journey() -> Any:
            await send(fox, subscribe)
            lidar.publish("/scan", scan)
            return await until(fox, lambda data, binary: binary and data[0] == MESSAGE_DATA
                               and int.from_bytes(data[1:5], "little") == 1)

        async def unsubscribe(_frame: Any) -> None:
            await send(fox, {"op": "unsubscribe", "subscriptionIds": [1]})

        try:
            return await twice(walker, journey, unsubscribe, quiet=(fox,))
        finally:
            fox.close()
            lidar.close()


async def fleet_dispatch(walker: Walker, folder: Path) -> Walk:
    """3. /fleet/dispatch to a POI, from the client's call to its reply."""
    async with fleet_world(folder) as server:
        robots = Latest(server.bus, "/fleet/robots", "hitrobot_msgs/FleetRobots")
        await eventually(robots.all_idle, "both robots idle")
        client = rosbridge_client(server)
        await add_poi_once(client, "walk", 14.0)
        dispatch = {"op": "call_service", "id": "dispatch", "service": "/fleet/dispatch",
                    "args": {"poi": "walk", "pose": pose(0.0, 0.0), "robot": ""}}

        async def cancel(reply: Any) -> None:  # before the robot moves: it stays where it was
            values = json.loads(reply)["values"]
            assert values["accepted"] and values["robot"], values
            await request(client, {"op": "call_service", "id": "cancel",
                                   "service": "/fleet/cancel", "args": {"task": values["task"]}},
                          op_is("service_response", id="cancel"))

        async def idle_again() -> None:  # the fleet has heard the robot stop
            await asyncio.sleep(1.0)
            await eventually(robots.all_idle, "both robots idle again")

        try:
            return await twice(walker, lambda: request(
                client, dispatch, op_is("service_response", id="dispatch")), cancel,
                quiet=(client,), between=idle_again)
        finally:
            client.close()
            robots.close()


async def poi_durable(walker: Walker, folder: Path) -> Walk:
    """4. /map_manager/add_poi from the client's frame to its acknowledgement, which comes
    once the state store's writer thread has fsynced the change."""
    async with single_robot_world(folder) as server:
        client = rosbridge_client(server)
        await add_poi_once(client, "first", 1.0)  # also advertises and asks for info statuses
        add = {"op": "publish", "topic": "/map_manager/add_poi",
               "msg": {"type": 100, "name": "walk", "remarks": "", "pose": pose(2.0, 1.0)}}
        delete = {"op": "publish", "topic": "/map_manager/delete_poi", "msg": {"name": "walk"}}
        await send(client, {"op": "advertise", "topic": "/map_manager/delete_poi",
                            "type": "map_messages/DeletePointOfInterest"})

        async def undo(_status: Any) -> None:  # the next run adds it again to the same list
            await request(client, delete, status_of("delete_poi"))

        try:
            return await twice(walker, lambda: request(client, add, status_of("add_poi")), undo,
                               quiet=(client,))
        finally:
            client.close()


JOURNEYS: list[tuple[str, Callable[[Walker, Path], Awaitable[Walk]]]] = [
    ("rosbridge publish", rosbridge_publish),
    ("foxglove subscribe /scan", foxglove_scan),
    ("fleet dispatch", fleet_dispatch),
    ("poi durable", poi_durable),
    ("call_service", call_service),
]


# ---------------------------------------------------------------------- helpers of the journeys
async def twice(walker: Walker, journey: Callable[[], Awaitable[T]],
                after: Callable[[T], Awaitable[object]] | None = None, *,
                quiet: tuple[Client, ...] = (),
                between: Callable[[], Awaitable[None]] | None = None) -> Walk:
    """The journey once unmeasured (first-use caches warm), then measured."""
    walk = None
    for measure in (False, True):
        if between is not None and measure:
            await between()
        walk, _ = await walker.run(journey, after, measure=measure, quiet=quiet)
    assert walk is not None
    return walk


def anything(_data: Any, _binary: bool) -> bool:
    return True


async def add_poi_once(client: Session, name: str, x: float) -> None:
    """A POI on the map, through the client (which hears info statuses from then on)."""
    await request(client, {"op": "set_level", "level": "info"}, op_is("status"))
    await send(client, {"op": "advertise", "topic": "/map_manager/add_poi", "type": POI_T})
    await request(client, {"op": "publish", "topic": "/map_manager/add_poi", "msg": {
        "type": 100, "name": name, "remarks": "", "pose": pose(x, CORRIDOR)}},
        status_of("add_poi"))


async def one_message(bus: Bus, topic: str, type_name: str) -> dict:
    """The next message on ``topic``, as its publisher made it."""
    got: list[dict] = []
    node = Node(bus, "/walk_capture")
    node.subscribe(topic, type_name, lambda message: got.append(message.msg))
    try:
        await eventually(lambda: bool(got), f"a message on {topic}")
    finally:
        node.close()
    return got[0]


class Latest:
    """The latest message of a topic, kept by a node of the bench."""

    def __init__(self, bus: Bus, topic: str, type_name: str) -> None:
        self.msg: dict | None = None
        self.node = Node(bus, "/walk_watch")
        self.node.subscribe(topic, type_name, self._got)

    def _got(self, message: Any) -> None:
        self.msg = message.msg

    def all_idle(self) -> bool:
        robots = (self.msg or {}).get("robots", [])
        return bool(robots) and all(r["state"] == "idle" and not r["task"] for r in robots)

    def close(self) -> None:
        self.node.close()


async def main() -> None:
    walker = Walker()
    with tempfile.TemporaryDirectory(prefix="bench-walk-") as tmp:
        # a safety net under the folders given to each server: never the user's own
        os.environ["XDG_STATE_HOME"] = os.path.join(tmp, "xdg-state")
        os.environ["XDG_DATA_HOME"] = os.path.join(tmp, "xdg-data")
        for number, (name, journey) in enumerate(JOURNEYS):
            runs: list[tuple[int, int, int]] = []
            walk = None
            for run in range(RUNS):
                walk = await journey(walker, Path(tmp) / f"{number}-{run}")
                runs.append(walk.figures())
            assert walk is not None
            walk.report(name, runs)
    threading.setprofile(None)


if __name__ == "__main__":
    asyncio.run(main())

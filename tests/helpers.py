"""Test clients that speak the protocol over real loopback sockets."""

from __future__ import annotations

import asyncio
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from abc import ABC, abstractmethod
from collections.abc import Callable

import cbor2
import orjson
import roslibpy
from websockets.asyncio.client import connect


def connect_roslibpy(port: int) -> roslibpy.Ros:
    """A connected roslibpy client (Twisted transport) of a server on loopback."""
    r = roslibpy.Ros(host="127.0.0.1", port=port)
    r.run(timeout=10)
    assert r.is_connected
    return r


async def until(predicate: Callable[[], object], what: str, timeout: float = 2.0) -> None:
    """Wait (polling, bounded) for an in-process condition."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"never saw {what} within {timeout}s")
        await asyncio.sleep(0.01)


async def round_trip(client, timeout: float = 5.0) -> None:
    """A connection's ops are handled in order: once this call is answered, every op the
    client sent before it (subscribe, advertise, ...) has been handled too."""
    op_id = f"round_trip:{time.monotonic_ns()}"
    await client.send({"op": "call_service", "id": op_id, "service": "/rosapi/get_time"})
    await client.expect(op="service_response", id=op_id, timeout=timeout)


def matches(msg: dict, **fields) -> bool:
    return all(msg.get(k) == v for k, v in fields.items())


class ProtocolClient(ABC):
    """What every test client does with decoded messages: wait for one, or for none.

    Subclasses carry the ops: over a socket (``WsClient``) or into a Session directly
    (``tests.sansio.SessionClient``)."""

    def __init__(self) -> None:
        self.seen: list[dict] = []

    @abstractmethod
    async def send(self, obj: dict | str) -> None:
        """Send one op (a dict, or text as it is)."""

    @abstractmethod
    async def recv(self, timeout: float = 5.0) -> dict:
        """The next decoded message (recorded in ``seen``)."""

    async def expect(self, pred: Callable[[dict], bool] | None = None, timeout: float = 5.0,
                     **fields) -> dict:
        """The first message satisfying ``pred`` and ``fields``; others are skipped."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                recent = [str(m)[:200] for m in self.seen[-5:]]
                raise AssertionError(f"no message matching {fields} within {timeout}s; "
                                     f"saw {recent}")
            try:
                msg = await self.recv(left)
            except TimeoutError:
                continue
            if matches(msg, **fields) and (pred is None or pred(msg)):
                return msg

    async def expect_none(self, timeout: float = 0.3, **fields) -> None:
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            try:
                msg = await self.recv(left)
            except TimeoutError:
                return
            assert not matches(msg, **fields), f"unexpected {msg}"

    async def call(self, service: str, args=None, timeout: float = 5.0, **extra) -> dict:
        op_id = f"call:{service}:{time.monotonic_ns()}"
        await self.send({"op": "call_service", "id": op_id, "service": service,
                         "args": args or {}, **extra})
        return await self.expect(op="service_response", id=op_id, timeout=timeout)


def decode_frame(frame: str | bytes, binary: bool) -> dict:
    """A JSON text frame or a CBOR binary frame, as the test sees it."""
    if binary:
        msg = cbor2.loads(frame)
        msg["_binary"] = True
        return msg
    return orjson.loads(frame)


class WsClient(ProtocolClient):
    """A raw protocol client over a real WebSocket; decodes JSON text and CBOR binary frames."""

    def __init__(self, ws):
        super().__init__()
        self.ws = ws

    @classmethod
    async def open(cls, port: int, **kw) -> WsClient:
        ws = await connect(f"ws://127.0.0.1:{port}", max_size=None, **kw)
        return cls(ws)

    async def send(self, obj: dict | str) -> None:
        await self.ws.send(obj if isinstance(obj, str) else json.dumps(obj))

    async def recv(self, timeout: float = 5.0) -> dict:
        frame = await asyncio.wait_for(self.ws.recv(), timeout)
        msg = decode_frame(frame, isinstance(frame, bytes))
        self.seen.append(msg)
        return msg

    async def close(self) -> None:
        await self.ws.close()


class TcpClient:
    """A raw TCP protocol client; reads newline-delimited JSON."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter):
        self.reader = reader
        self.writer = writer

    @classmethod
    async def open(cls, port: int) -> TcpClient:
        reader, writer = await asyncio.open_connection("127.0.0.1", port, limit=2**26)
        return cls(reader, writer)

    async def send_bytes(self, data: bytes) -> None:
        self.writer.write(data)
        await self.writer.drain()

    async def send(self, obj: dict) -> None:
        await self.send_bytes(json.dumps(obj).encode())

    async def recv(self, timeout: float = 5.0) -> dict:
        line = await asyncio.wait_for(self.reader.readline(), timeout)
        if not line:
            raise ConnectionError("closed")
        return orjson.loads(line)

    async def expect(self, timeout: float = 5.0, **fields) -> dict:
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            msg = await self.recv(left)
            if matches(msg, **fields):
                return msg
        raise AssertionError(f"no message matching {fields}")

    async def close(self) -> None:
        self.writer.close()


class ServerProcess:
    """``hitrobot-server`` run for real as a subprocess on ephemeral loopback ports. Unless
    ``--state-dir`` is among ``args`` it gets a temporary one (removed on :meth:`stop`), so no
    test writes to the user's real state folder or shares state with another run."""

    def __init__(self, *args: str, robot: str = "none", command: tuple[str, ...] = ()):
        """``command``: a tool that serves like the server (``("replay", FILE)``)."""
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self._own_state: str | None = None
        if "--state-dir" not in args:
            self._own_state = tempfile.mkdtemp(prefix="hitrobot-state-")
            args = (*args, "--state-dir", self._own_state)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "hitrobot_server", *command, "--port", "0", "--tcp-port", "-1",
             "--address", "127.0.0.1", "--robot", robot, *args],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
        )
        deadline = time.monotonic() + 30
        self.output: list[str] = []
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.output.append(line)
            m = re.search(r"ws://[\d.]+:(\d+)(?:\s+tcp://[\d.]+:(\d+))?", line)
            if m:
                self.port = int(m.group(1))
                self.tcp_port = int(m.group(2)) if m.group(2) else None
                return
        self.stop()
        raise RuntimeError("server did not start:\n" + "".join(self.output))

    def kill(self) -> None:
        """SIGKILL, as a power cut or an OOM kill: nothing of the server runs after it."""
        self.proc.kill()
        self.proc.wait(10)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        if self._own_state is not None:
            shutil.rmtree(self._own_state, ignore_errors=True)


class Watcher:
    """A WebSocket client that keeps every message per topic and every status, in the
    background, so robot tests can wait for conditions on the latest state."""

    def __init__(self, client: WsClient):
        self.client = client
        self.messages: dict[str, list[tuple[float, dict]]] = {}
        self.statuses: list[dict] = []
        self.replies: dict[str, dict] = {}
        self._task = asyncio.ensure_future(self._read())

    @classmethod
    async def open(cls, port: int) -> Watcher:
        return cls(await WsClient.open(port))

    async def _read(self) -> None:
        while True:
            try:
                msg = await self.client.recv(timeout=3600)
            except Exception:
                return
            self.client.seen.clear()  # the watcher keeps its own records
            op = msg.get("op")
            if op == "publish":
                self.messages.setdefault(msg["topic"], []).append((time.monotonic(), msg["msg"]))
            elif op == "status":
                self.statuses.append(msg)
            elif op == "service_response":
                self.replies[msg.get("id")] = msg

    async def subscribe(self, topic: str, type_name: str | None = None, **extra) -> None:
        op = {"op": "subscribe", "id": f"w:{topic}", "topic": topic, **extra}
        if type_name:
            op["type"] = type_name
        await self.client.send(op)

    async def publish(self, topic: str, msg: dict, type_name: str | None = None,
                      op_id: str | None = None) -> None:
        if type_name:
            await self.client.send({"op": "advertise", "topic": topic, "type": type_name})
        op = {"op": "publish", "topic": topic, "msg": msg}
        if op_id:
            op["id"] = op_id
        await self.client.send(op)

    async def call(self, service: str, args: dict | None = None, timeout: float = 10) -> dict:
        op_id = f"call:{service}:{time.monotonic_ns()}"
        await self.client.send({"op": "call_service", "id": op_id, "service": service,
                                "args": args or {}})
        await self.until(lambda: op_id in self.replies, timeout, f"reply from {service}")
        return self.replies.pop(op_id)

    def latest(self, topic: str) -> dict | None:
        got = self.messages.get(topic)
        return got[-1][1] if got else None

    async def next(self, topic: str, timeout: float = 10) -> dict:
        """The first message on ``topic`` that arrives after this call."""
        count = len(self.messages.get(topic, []))
        await self.until(lambda: len(self.messages.get(topic, [])) > count, timeout,
                         f"a new message on {topic}")
        return self.messages[topic][-1][1]

    async def until(self, predicate: Callable[[], object], timeout: float, what: str):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            value = predicate()
            if value:
                return value
            await asyncio.sleep(0.05)
        raise AssertionError(f"timed out after {timeout}s waiting for {what}")

    async def close(self) -> None:
        self._task.cancel()
        await self.client.close()


async def silent_provider(port: int, service: str = "/mute") -> WsClient:
    """A client providing ``service`` (std_srvs/Trigger) that answers only when a test makes
    it: the provider that never answers, of the pending-call tests."""
    provider = await WsClient.open(port)
    await provider.send({"op": "set_level", "level": "info"})
    await provider.send({"op": "advertise_service", "id": "adv", "service": service,
                         "type": "std_srvs/Trigger"})
    await provider.expect(op="status", id="adv")
    return provider

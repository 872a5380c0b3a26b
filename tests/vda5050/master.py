"""A plain MQTT master for the VDA 5050 tests (aiomqtt): publishes whatever it is given on a
vehicle's topics, reads every state, connection and factsheet, and waits for a state that
satisfies a condition (bounded)."""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Callable

import aiomqtt
import orjson

from hitrobot_server.vda5050.schemas import problem

HEADER = {"timestamp": "2024-01-01T00:00:00.00Z", "version": "2.0.0"}


class Master:
    def __init__(self, port: int, serial: str = "robot", manufacturer: str = "hitrobot",
                 online: bool = True):
        self.port, self.serial, self.manufacturer = port, serial, manufacturer
        self.online = online  # wait for the vehicle ONLINE on entering
        self.base = f"uagv/v2/{manufacturer}/{serial}"
        self.seen: dict[str, list[dict]] = {}
        self.invalid: list[str] = []
        self.headers: dict[str, int] = {}
        self._changed = asyncio.Event()
        self._stack = contextlib.AsyncExitStack()
        self._task: asyncio.Task | None = None
        self.client: aiomqtt.Client | None = None

    async def __aenter__(self) -> Master:
        self.client = await self._stack.enter_async_context(
            aiomqtt.Client("127.0.0.1", self.port, max_queued_incoming_messages=10_000))
        await self.client.subscribe(f"{self.base}/#")
        self._task = asyncio.get_running_loop().create_task(self._read())
        if self.online:
            await self.wait(lambda: any(c["connectionState"] == "ONLINE"
                                        for c in self.seen.get("connection", [])),
                            "the vehicle ONLINE (it listens from then on)")
        return self

    async def __aexit__(self, *exc) -> None:
        if self._task is not None:
            self._task.cancel()
            await asyncio.gather(self._task, return_exceptions=True)
        await self._stack.aclose()

    async def _read(self) -> None:
        async for message in self.client.messages:
            topic = str(message.topic).rsplit("/", 1)[-1]
            if topic in ("order", "instantActions"):
                continue
            body = orjson.loads(message.payload)
            why = problem(topic, body)
            if why is not None:
                self.invalid.append(f"{topic}: {why}")
            self.seen.setdefault(topic, []).append(body)
            self._changed.set()

    def header(self, topic: str, **more) -> dict:
        n = self.headers.get(topic, 0) + 1
        self.headers[topic] = n
        return {"headerId": n, **HEADER, "manufacturer": self.manufacturer,
                "serialNumber": self.serial, **more}

    async def send(self, topic: str, body: dict | bytes) -> None:
        payload = body if isinstance(body, bytes) else orjson.dumps(body)
        await self.client.publish(f"{self.base}/{topic}", payload)

    async def order(self, order_id: str, update: int, nodes: list[dict],
                    **more) -> dict:
        edges = [{"edgeId": f"{a['nodeId']}-{b['nodeId']}", "sequenceId": a["sequenceId"] + 1,
                  "startNodeId": a["nodeId"], "endNodeId": b["nodeId"],
                  "released": b["released"], "actions": []}
                 for a, b in zip(nodes, nodes[1:], strict=False)]
        body = self.header("order", orderId=order_id, orderUpdateId=update, nodes=nodes,
                           edges=edges, **more)
        await self.send("order", body)
        return body

    async def instant(self, *actions: dict) -> dict:
        body = self.header("instantActions", actions=list(actions))
        await self.send("instantActions", body)
        return body

    async def sync(self, timeout: float = 10.0) -> dict:
        """A stateRequest answered: every message sent before it has been taken."""
        action_id = f"sync-{time.monotonic_ns()}"
        await self.instant(action("stateRequest", action_id))
        return await self.state(lambda s: any(a["actionId"] == action_id and
                                              a["actionStatus"] == "FINISHED"
                                              for a in s["actionStates"]),
                                f"the answer to {action_id}", timeout)

    @property
    def last(self) -> dict:
        return self.seen["state"][-1]

    async def state(self, pred: Callable[[dict], bool], what: str,
                    timeout: float = 10.0) -> dict:
        found: list[dict] = []

        def seen() -> bool:
            found[:] = [s for s in self.seen.get("state", [])[-3:] if pred(s)][-1:]
            return bool(found)

        await self.wait(seen, what, timeout)
        return found[0]

    async def wait(self, pred: Callable[[], bool], what: str, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while not pred():
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no {what} in {timeout} s; last state: "
                                     f"{self.seen.get('state', [{}])[-1]}")
            self._changed.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._changed.wait(), left)


def node(node_id: str, seq: int, x: float, y: float, released: bool = True,
         map_id: str = "map", actions: list[dict] | None = None) -> dict:
    return {"nodeId": node_id, "sequenceId": seq, "released": released,
            "actions": actions or [], "nodePosition": {"x": x, "y": y, "mapId": map_id}}


def action(kind: str, action_id: str, **params) -> dict:
    return {"actionId": action_id, "actionType": kind, "blockingType": "HARD",
            "actionParameters": [{"key": k, "value": v} for k, v in params.items()]}


def has_error(kind: str, text: str = "") -> Callable[[dict], bool]:
    return lambda s: any(err["errorType"] == kind and text in err.get("errorDescription", "")
                         for err in s["errors"])

"""The thin transport: one aiomqtt connection per vehicle (its own Last Will), topics
``INTERFACE/v2/MANUFACTURER/SERIAL/...``; reconnects with back-off; never blocks the loop
(aiomqtt drives its socket from the event loop; messages out wait in a bounded queue).

``connection`` ONLINE is sent retained at QoS 1 on every connect, the Will is CONNECTIONBROKEN
(retained, QoS 1), a clean stop sends OFFLINE before it disconnects."""

from __future__ import annotations

import asyncio
import collections
import logging
import ssl
from typing import Any

import orjson

from .messages import CONNECTIONBROKEN, OFFLINE
from .options import Broker
from .schemas import MAJOR
from .vehicle import Vehicle

log = logging.getLogger(__name__)

BACKOFF_FIRST, BACKOFF_MAX = 0.5, 30.0
"""Seconds before the first reconnection, doubled up to the last."""
OUTBOX = 64
"""Messages waiting to go out; past it the oldest state or visualization gives way."""
INBOX = 256
"""Messages the client holds before the vehicle reads them; past it the broker's are dropped."""
STOP_TIMEOUT = 3.0


def base_topic(interface: str, manufacturer: str, serial: str) -> str:
    return f"{interface}/{MAJOR}/{manufacturer}/{serial}"


class MqttLink:
    """One vehicle's connection to the broker."""

    def __init__(self, vehicle: Vehicle, broker: Broker, interface: str, manufacturer: str, *,
                 password: str | None = None, tls: ssl.SSLContext | None = None):
        self.vehicle, self.broker, self.tls = vehicle, broker, tls
        self.password = password
        self.base = base_topic(interface, manufacturer, vehicle.serial)
        self.connected = False
        self.last_error = ""
        self._out: collections.deque[tuple[str, bytes, int, bool]] = collections.deque()
        self._ready = asyncio.Event()
        self._client: Any = None
        self._task: asyncio.Task | None = None
        self._stopping = False
        vehicle.send = self.send

    def send(self, subtopic: str, message: dict, retain: bool) -> None:
        """Queue a message; never waits. Connection and factsheet go at QoS 1."""
        qos = 1 if subtopic in ("connection", "factsheet") else 0
        if len(self._out) >= OUTBOX:
            old = next((m for m in self._out if m[0] in ("state", "visualization")), None)
            if old is None:
                return
            self._out.remove(old)
        self._out.append((subtopic, orjson.dumps(message), qos, retain))
        self._ready.set()

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run())

    async def _run(self) -> None:
        import aiomqtt

        delay = BACKOFF_FIRST
        while not self._stopping:
            try:
                await self._session(aiomqtt)
            except aiomqtt.MqttError as exc:
                self.last_error = str(exc) or type(exc).__name__
            except OSError as exc:
                self.last_error = str(exc)
            except Exception as exc:  # a fault of ours: logged, and the link tries again
                log.exception("vda5050 %s: the link failed", self.vehicle.serial)
                self.last_error = f"internal error: {exc}"
            was = self.connected
            self.connected = False
            self._client = None
            self.vehicle.on_change()
            if self._stopping:
                return
            if was:
                delay = BACKOFF_FIRST
            log.warning("vda5050 %s: broker %s: %s; again in %.1f s", self.vehicle.serial,
                        self.broker.url, self.last_error, delay)
            await asyncio.sleep(delay)
            delay = min(delay * 2, BACKOFF_MAX)

    async def _session(self, aiomqtt: Any) -> None:
        will = aiomqtt.Will(f"{self.base}/connection", orjson.dumps(
            self.vehicle.offline_message(CONNECTIONBROKEN)), qos=1, retain=True)
        async with aiomqtt.Client(
                self.broker.host, self.broker.port, username=self.broker.username,
                password=self.password, identifier=f"{self.base.replace('/', '_')}",
                will=will, tls_context=self.tls, keepalive=15, timeout=10.0,
                max_queued_incoming_messages=INBOX) as client:
            self._client = client
            await client.subscribe(f"{self.base}/order", qos=0)
            await client.subscribe(f"{self.base}/instantActions", qos=0)
            self.connected, self.last_error = True, ""
            self._out.clear()  # what waited while offline is stale: online() says it anew
            log.info("vda5050 %s: connected to %s as %s", self.vehicle.serial,
                     self.broker.url, self.base)
            self.vehicle.online()
            writer = asyncio.get_running_loop().create_task(self._write(client))
            try:
                async for message in client.messages:
                    subtopic = str(message.topic).rsplit("/", 1)[-1]
                    payload = message.payload
                    if isinstance(payload, bytes | bytearray):
                        try:
                            self.vehicle.receive(subtopic, bytes(payload))
                        except Exception:  # a fault of ours: logged, the link goes on
                            log.exception("vda5050 %s: a %s message failed",
                                          self.vehicle.serial, subtopic)
                        await asyncio.sleep(0)  # a flood shares the loop with the rest
            finally:
                writer.cancel()
                await asyncio.gather(writer, return_exceptions=True)

    async def _write(self, client: Any) -> None:
        while True:
            await self._ready.wait()
            self._ready.clear()
            while self._out:
                subtopic, payload, qos, retain = self._out[0]
                await client.publish(f"{self.base}/{subtopic}", payload, qos=qos, retain=retain)
                self._out.popleft()

    async def stop(self) -> None:
        """OFFLINE (retained), then disconnect; the Will is not sent on a clean stop."""
        self._stopping = True
        client = self._client
        if client is not None and self.connected:
            try:
                await asyncio.wait_for(client.publish(
                    f"{self.base}/connection", orjson.dumps(self.vehicle.offline_message(OFFLINE)),
                    qos=1, retain=True), STOP_TIMEOUT)
            except Exception as exc:  # noqa: BLE001 - the broker may be gone: we stop anyway
                log.info("vda5050 %s: OFFLINE not sent: %s", self.vehicle.serial, exc)
        if self._task is not None:
            self._task.cancel()
            await asyncio.gather(self._task, return_exceptions=True)
        self.connected = False


def tls_context(ca_file: str | None, cert_file: str | None,
                key_file: str | None) -> ssl.SSLContext:
    """The client's TLS: the broker checked against ``ca_file`` (else the system's CAs), and
    a client certificate when given."""
    context = ssl.create_default_context(cafile=ca_file)
    if cert_file:
        context.load_cert_chain(cert_file, key_file)
    return context

"""``GET /metrics`` (the Prometheus text format, through ``prometheus_client``) and ``GET
/healthz`` (JSON, 200 or 503): what a site's tools watch.

Nothing is computed on the hot paths but plain int counts: the outboxes count what each client
was sent and what was thinned per topic (session/traffic.py), a bus tap counts what clients
published per topic, and a small task measures how late the event loop wakes up. Everything
else (clients, queued bytes, requests in flight, robot links, the state stores, the recorder,
the resident memory of every process of the server) is read when a scrape asks. The per-topic
families (5 of at most 2,001 samples: 2,000 topics by name and the others together, 300-450 kB
of text at the bound) are formatted in a thread from a copy of the counts, at most once a
second; scrapes that come while a page is being made share it. A storm of 200 scrapes at once
stalled the loop 2.9 s (each formatted on it); it costs the other clients nothing now.

``/healthz``'s ``robots`` check fails for a robot that is not reachable, and for one that is
but answers errors or nonsense (its link's ``trouble``: HTTP 500, not JSON, a body over its
bound), with that answer as the link's ``reason``.

With ``--workers N`` every sample carries a ``worker`` label, and a scrape, whichever worker
the kernel hands it to, covers them all: each worker also serves its own samples on a unix
socket in the workers' private folder (``$HITROBOT_METRICS_DIR``, set by the parent), and the
worker that answers reads the others' there (bounded in size and time) and merges them into
one family per name. Each worker reports its own memory and its children's; worker 0 also
the parent's.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.exposition import CONTENT_TYPE_LATEST
from prometheus_client.parser import text_string_to_metric_families

from . import procmem
from .bus.names import CLIENT_NODE_PREFIX
from .bus.tap import ClientOp
from .bus.topics import Message
from .record.control import RecordingControl
from .robots import RobotUnit
from .session.client import ClientSession
from .session.foxglove.session import FoxgloveSession
from .session.rosbridge.session import Session
from .session.traffic import Traffic, counts_of
from .site import SiteUnit
from .state import StateStore
from .wire.memo import size_of

METRICS_DIR = "HITROBOT_METRICS_DIR"  # the environment variable the --workers parent sets
PEER_TIMEOUT = 2.0  # seconds to read another worker's samples
PEER_LIMIT = 32 * 1024 * 1024  # bytes of another worker's samples, at most
LOOP_PERIOD = 0.5  # seconds between the loop watch's wake-ups
LOOP_STALL = 2.0  # a wake-up this late (or none for this long): the loop is not answering
TOPICS_EVERY = 1.0
"""Seconds a per-topic text serves the scrapes after it (the rest is read on each scrape)."""
Page = tuple[int, str, bytes]  # status, content type, body


class ClientPublishes:
    """A bus tap: messages and bytes clients published, per topic (the op's size), for at
    most :data:`~.session.traffic.MAX_TOPICS` topics by name (the rest together). Every
    message counts its bytes: a small one nobody subscribed to used to count none (its size
    was only known once a subscriber asked)."""

    def __init__(self) -> None:
        self.received: dict[str, list[int]] = {}

    def message(self, message: Message) -> None:
        origin = message.origin
        if origin is None or not origin.node.startswith(CLIENT_NODE_PREFIX):
            return
        size = size_of(message)  # the op's length, or (no op seen: Foxglove) an estimate
        counts = self.received.get(message.topic.name)
        if counts is None:
            counts = counts_of(self.received, message.topic.name, lambda: [0, 0])
        counts[0] += 1
        counts[1] += size

    def client_op(self, op: ClientOp) -> None:
        """Client calls are not counted here."""


class LoopWatch:
    """How late the event loop wakes up: a task that sleeps ``LOOP_PERIOD`` and measures."""

    def __init__(self) -> None:
        self.lag = 0.0
        self.last = time.monotonic()
        self._task: asyncio.Task | None = None

    def start(self) -> None:
        self._task = asyncio.ensure_future(self._run())

    def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()

    async def _run(self) -> None:
        while True:
            before = time.monotonic()
            await asyncio.sleep(LOOP_PERIOD)
            self.last = time.monotonic()
            self.lag = max(0.0, self.last - before - LOOP_PERIOD)

    @property
    def answering(self) -> bool:
        return self.lag < LOOP_STALL and time.monotonic() - self.last < LOOP_PERIOD + LOOP_STALL


@dataclass
class Sources:
    """What the metrics read, from the server (callables: the server replaces its lists)."""

    sessions: Callable[[], Iterable[ClientSession]]
    robots: Callable[[], list[RobotUnit]]
    site: Callable[[], SiteUnit]  # its folder holds the fleet's tasks and the site's POIs
    recording: Callable[[], RecordingControl | None]
    worker: int | None  # which of --workers, None for a single process


class ServerMetrics:
    """The collector behind ``/metrics`` and the checks behind ``/healthz``."""

    def __init__(self, sources: Sources):
        self.sources = sources
        self.traffic = Traffic()  # every session's outbox counts into it
        self.publishes = ClientPublishes()  # the bus tap
        self.loop = LoopWatch()
        self._registry = CollectorRegistry(auto_describe=False)
        self._registry.register(self)
        self._folder: Path | None = None
        self._share: asyncio.AbstractServer | None = None
        self._making: asyncio.Future[bytes] | None = None  # this process's page being made
        self._topics: asyncio.Future[bytes] | None = None  # the per-topic text, or its making
        self._topics_at = float("-inf")

    # ------------------------------------------------------------------ --workers
    async def share(self, folder: str) -> None:
        """Serve this worker's samples to the other workers on ``folder``/metrics-N.sock."""
        self._folder = Path(folder)

        async def send(_reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            writer.write(await self._own())
            with contextlib.suppress(ConnectionError, TimeoutError):
                await asyncio.wait_for(writer.drain(), PEER_TIMEOUT)
            writer.close()

        self._share = await asyncio.start_unix_server(
            send, str(self._folder / f"metrics-{self.sources.worker}.sock"))

    def unshare(self) -> None:
        if self._share is not None:
            self._share.close()
            self._share = None

    async def _peers(self) -> list[str]:
        """The other workers' samples (those that answer in time)."""
        if self._folder is None:
            return []
        own = f"metrics-{self.sources.worker}.sock"
        paths = [p for p in self._folder.glob("metrics-*.sock") if p.name != own]
        texts = await asyncio.gather(*(_read_peer(p) for p in paths))
        return [t for t in texts if t]

    # ------------------------------------------------------------------ pages
    async def metrics_page(self) -> Page:
        own = await self._own()
        peers = await self._peers()
        if not peers:
            return 200, CONTENT_TYPE_LATEST, own
        return 200, CONTENT_TYPE_LATEST, _merged([own.decode(), *peers])

    async def health_page(self) -> Page:
        health = self.health()
        body = json.dumps(health, indent=1).encode() + b"\n"
        return (200 if health["ok"] else 503), "application/json", body

    async def _own(self) -> bytes:
        """This process's samples; the scrapes that come while they are being made share
        them (one page in memory for a storm of scrapes, not one each)."""
        making = self._making
        if making is None or making.done():
            making = self._making = asyncio.ensure_future(self._make_own())
        return await asyncio.shield(making)

    async def _make_own(self) -> bytes:
        """The per-topic families (:meth:`_topic_text`), then the small families, read now
        on the loop (a few dozen samples)."""
        topics = await self._topic_text()
        return generate_latest(self._registry) + topics

    async def _topic_text(self) -> bytes:
        """The per-topic families, formatted off the event loop from a copy of the counts
        (at most 3 × 2,001 entries, taken on the loop), at most once per :data:`TOPICS_EVERY`
        whatever the scrapes' rate: a scrape storm shares one text, at most that old."""
        now = time.monotonic()
        render = self._topics
        if render is None or render.done() and now - self._topics_at >= TOPICS_EVERY:
            tables = (dict(self.publishes.received), dict(self.traffic.sent),
                      dict(self.traffic.thinned))
            worker = None if self.sources.worker is None else str(self.sources.worker)
            self._topics_at = now
            render = self._topics = asyncio.ensure_future(
                asyncio.to_thread(_topic_exposition, tables, worker))
        return await asyncio.shield(render)

    # ------------------------------------------------------------------ health
    def health(self) -> dict[str, Any]:
        robots = [_link_health(u) for u in self.sources.robots() if u.backend is not None]
        state = [_state_health(u) for u in self.sources.robots() if u.state.store is not None]
        site = self.sources.site().state.store
        recorder = _recorder_health(self.sources.recording())
        checks = {
            "loop": {"ok": self.loop.answering, "lag_seconds": round(self.loop.lag, 4)},
            "robots": {"ok": all(r["connected"] and "reason" not in r for r in robots),
                       "links": robots},
            "recorder": recorder,
            "state": {"ok": all(s["ok"] for s in state) and (site is None or site.healthy),
                      "stores": state,
                      **({"site": _store_health(site)} if site is not None else {})},
            "workers": _workers_health(self.sources.worker),
        }
        return {"ok": all(c["ok"] for c in checks.values()), **checks}

    # ------------------------------------------------------------------ metrics
    def collect(self) -> Iterator[Metric]:
        """prometheus_client's collector interface: every family but the per-topic ones
        (:meth:`_topic_text`), read now."""
        worker = [] if self.sources.worker is None else [str(self.sources.worker)]
        labels = [] if self.sources.worker is None else ["worker"]
        yield from self._clients(labels, worker)
        yield from self._robots(labels, worker)
        yield from self._recorder(labels, worker)
        rss = GaugeMetricFamily("hitrobot_process_resident_bytes",
                                "resident memory of each process of the server",
                                labels=["pid", "role"])
        for pid, role in _server_processes(self.sources.worker):
            rss.add_metric([str(pid), role], procmem.rss_bytes(pid))
        yield rss
        lag = GaugeMetricFamily("hitrobot_event_loop_lag_seconds",
                                "how late the event loop last woke up", labels=labels)
        lag.add_metric(worker, self.loop.lag)
        yield lag

    def _clients(self, labels: list[str], worker: list[str]) -> Iterator[Metric]:
        clients = GaugeMetricFamily("hitrobot_clients", "connected clients",
                                    labels=[*labels, "protocol", "transport"])
        queued = GaugeMetricFamily("hitrobot_queued_bytes",
                                   "bytes waiting in the clients' send buffers", labels=labels)
        flight = GaugeMetricFamily("hitrobot_requests_in_flight",
                                   "clients' service calls waiting for their answer",
                                   labels=labels)
        counts: dict[tuple[str, str], int] = {}
        buffered = in_flight = 0
        for session in list(self.sources.sessions()):
            if isinstance(session, FoxgloveSession):
                kind = ("foxglove", "ws")
            elif isinstance(session, Session):
                kind = ("rosbridge", session.transport)
                in_flight += session.service_ops.in_flight
            else:
                kind = ("other", "")
            counts[kind] = counts.get(kind, 0) + 1
            buffered += session.outbox.buffered
        for kind in (("rosbridge", "ws"), ("rosbridge", "tcp"), ("foxglove", "ws")):
            counts.setdefault(kind, 0)
        for (protocol, transport), n in sorted(counts.items()):
            clients.add_metric([*worker, protocol, transport], n)
        queued.add_metric(worker, buffered)
        flight.add_metric(worker, in_flight)
        yield from (clients, queued, flight)

    def _robots(self, labels: list[str], worker: list[str]) -> Iterator[Metric]:
        up = GaugeMetricFamily("hitrobot_robot_link_up", "1 while the robot answers",
                               labels=[*labels, "robot"])
        failures = CounterMetricFamily("hitrobot_state_write_failures",
                                       "writes of the robot's state folder that failed",
                                       labels=[*labels, "robot"])
        for unit in self.sources.robots():
            name = unit.name or "robot"
            if unit.backend is not None:
                up.add_metric([*worker, name], 1 if _link_up(unit) else 0)
            if unit.state.store is not None:
                failures.add_metric([*worker, name], _write_failures(unit))
        site = self.sources.site().state.store
        site_failures = CounterMetricFamily("hitrobot_site_state_write_failures",
                                            "writes of the site's state folder that failed",
                                            labels=labels)
        if site is not None:
            site_failures.add_metric(worker, site.write_failures)
        yield from (up, failures, site_failures)

    def _recorder(self, labels: list[str], worker: list[str]) -> Iterator[Metric]:
        control = self.sources.recording()
        recorder = control.recorder if control is not None else None
        running = GaugeMetricFamily("hitrobot_recording", "1 while a recording runs",
                                    labels=labels)
        running.add_metric(worker, 1 if recorder is not None and recorder.alive else 0)
        dropped = CounterMetricFamily("hitrobot_recorder_dropped",
                                      "messages the current recording could not keep up with",
                                      labels=labels)
        dropped.add_metric(worker, recorder.dropped if recorder is not None else 0)
        yield from (running, dropped)


Tables = tuple[dict, dict, dict]
"""Copies of the per-topic counts: received ([n, bytes]), sent ([n, bytes]), thinned ([n])."""


def _topic_exposition(tables: Tables, worker: str | None) -> bytes:
    """The per-topic families of ``tables`` in the exposition format (run in a thread: 5
    families of at most 2,001 samples each, :data:`~.session.traffic.MAX_TOPICS` topics by
    name and the others together; a scrape is then at most 10,005 per-topic samples)."""
    labels, values = ([], []) if worker is None else (["worker"], [worker])
    by_topic = [*labels, "topic"]
    families = {
        name: CounterMetricFamily(f"hitrobot_{name}", doc, labels=by_topic)
        for name, doc in (
            ("messages_received", "messages clients published, per topic"),
            ("received_bytes", "bytes of the messages clients published, per topic"),
            ("messages_sent", "topic messages queued for clients, per topic"),
            ("sent_bytes", "bytes of the topic messages queued for clients, per topic"),
            ("messages_thinned", "topic messages dropped for slow clients, per topic"),
        )}
    received, sent, thinned = tables
    for topic, (n, size) in received.items():
        families["messages_received"].add_metric([*values, topic], n)
        families["received_bytes"].add_metric([*values, topic], size)
    for topic, (n, size) in sent.items():
        families["messages_sent"].add_metric([*values, str(topic)], n)
        families["sent_bytes"].add_metric([*values, str(topic)], size)
    for topic, (n,) in thinned.items():
        families["messages_thinned"].add_metric([*values, str(topic)], n)

    class Topics:
        def collect(self) -> Iterator[Metric]:
            return iter(families.values())

    registry = CollectorRegistry(auto_describe=False)
    registry.register(Topics())
    return generate_latest(registry)


async def _read_peer(path: Path) -> str:
    try:
        reader, writer = await asyncio.wait_for(asyncio.open_unix_connection(str(path)),
                                                PEER_TIMEOUT)
    except (OSError, TimeoutError):
        return ""  # a worker starting again, or gone
    try:
        data = await asyncio.wait_for(reader.read(PEER_LIMIT), PEER_TIMEOUT)
        return data.decode(errors="replace")
    except (OSError, TimeoutError):
        return ""
    finally:
        writer.close()


def _merged(texts: list[str]) -> bytes:
    """Several workers' samples as one exposition: one family per name (each sample keeps
    its ``worker`` label, so none repeats)."""
    families: dict[str, Metric] = {}
    for text in texts:
        for family in text_string_to_metric_families(text):
            merged = families.get(family.name)
            if merged is None:
                merged = families[family.name] = Metric(
                    family.name, family.documentation, family.type)
            merged.samples += family.samples

    class Merged:
        def collect(self) -> Iterator[Metric]:
            return iter(families.values())

    registry = CollectorRegistry(auto_describe=False)
    registry.register(Merged())
    return generate_latest(registry)


def _link_up(unit: RobotUnit) -> bool:
    return unit.backend is not None and unit.backend.link.connected


def _link_health(unit: RobotUnit) -> dict[str, Any]:
    """A robot's link: connected or not and, while a reachable robot answers errors or
    nonsense, the reason (which makes the check fail)."""
    assert unit.backend is not None
    link = {"robot": unit.name or "robot", "connected": _link_up(unit)}
    trouble = unit.backend.link.trouble if link["connected"] else ""
    return {**link, "reason": trouble} if trouble else link


def _write_failures(unit: RobotUnit) -> int:
    store = unit.state.store
    return 0 if store is None else store.write_failures


def _state_health(unit: RobotUnit) -> dict[str, Any]:
    store = unit.state.store
    assert store is not None
    return {"robot": unit.name or "robot", **_store_health(store)}


def _store_health(store: StateStore) -> dict[str, Any]:
    return {"ok": store.healthy, "writes": store.writes, "last_error": store.write_error or ""}


def _recorder_health(control: RecordingControl | None) -> dict[str, Any]:
    recorder = control.recorder if control is not None else None
    if recorder is None:
        return {"ok": True, "recording": False}
    return {"ok": recorder.alive, "recording": True, "file": recorder.path.name,
            "messages": recorder.messages, "dropped": recorder.dropped}


def _workers_health(worker: int | None) -> dict[str, Any]:
    """With --workers: the workers the parent runs now (this one answering)."""
    if worker is None:
        return {"ok": True, "workers": 1}
    running = [pid for pid in procmem.children(os.getppid()) if "--worker-id" in _cmdline(pid)]
    return {"ok": len(running) >= 1, "worker": worker, "running": len(running)}


def _server_processes(worker: int | None) -> list[tuple[int, str]]:
    """Every process of the server with its role: this one and its children; with
    ``--workers``, the parent, every worker and their children."""
    me = os.getpid()
    if worker is None:
        return [(me, "server"), *_children(me)]
    found = [(me, f"worker {worker}"), *_children(me)]
    if worker == 0:
        found.append((os.getppid(), "supervisor"))
    return found


def _children(pid: int) -> list[tuple[int, str]]:
    return [(child, _child_role(child)) for child in procmem.children(pid)]


def _cmdline(pid: int) -> list[str]:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace").split("\0")
    except OSError:
        return []


def _child_role(pid: int) -> str:
    text = " ".join(_cmdline(pid))
    if "resource_tracker" in text:
        return "resource tracker"
    if "spawn_main" in text:
        return "pool or recorder"
    return "child"

"""Assemble the bus, its nodes and the transports into one running server."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import ssl
from pathlib import Path
from typing import TypeVar

from . import __version__
from .bus.core import Bus
from .bus.rosout import RosoutHandler
from .bus.zenoh.keys import endpoints
from .config import Settings
from .metrics import METRICS_DIR, ServerMetrics, Sources
from .protocol import foxglove_layout
from .protocol.access import Grant, RoleTable, roles_from
from .protocol.auth import load_secret
from .protocol.foxglove import SUBPROTOCOLS as FOXGLOVE_SUBPROTOCOLS
from .record.blackbox_control import BlackBoxControl
from .record.control import RecordingControl
from .record.replay_launcher import ReplayLauncher
from .robot.capabilities import Robot
from .robots import RobotUnit, StartPlan, start_plan, start_planned, stop_robots
from .session.access import Access, WhoAmI
from .session.client import ClientSession, WireProtocols
from .session.foxglove.session import FoxgloveSession
from .session.foxglove.shared import FoxgloveShared
from .session.heap import HeapTrim
from .session.offload import WorkerPool
from .session.options import SessionOptions
from .session.rosbridge.session import Session, Shared
from .site import SiteUnit
from .state import StateBinding
from .state.tokens import TokenBook, tokens_path
from .transport.download import Downloads
from .transport.http import StaticFiles, WithRecordings, default_web_root, missing_libraries
from .transport.options import TransportOptions
from .transport.tcp import start_tcp
from .transport.tls import HandshakeGate
from .transport.websocket import start_websocket
from .types.registry import TypeRegistry
from .vda5050.service import RobotEntry as VdaRobot
from .vda5050.service import Vda5050Service

log = logging.getLogger(__name__)
T = TypeVar("T", bound=ClientSession)
PACKAGE_LOGGER = "hitrobot_server"  # every record of ours goes to /rosout too
WORKER_HEADER = "X-Hitrobot-Worker"  # which worker of --workers answered (handshake, HTTP)
LAYOUT_PATH = "/foxglove/layout.json"  # the Foxglove layout of this server's topics (HTTP)
POOL_MODULES = ("hitrobot_server.session.rosbridge.encodings",  # what the big ops run
                "hitrobot_server.session.rosbridge.frames", "hitrobot_server.protocol.bulk")


class HitrobotServer:
    """The bridge: ``await start()``, read ``port``/``tcp_port``, ``await stop()``. What it
    starts is ``plan`` (by default the settings' own, :func:`~.robots.start_plan`)."""

    def __init__(self, settings: Settings | None = None, types: TypeRegistry | None = None,
                 plan: StartPlan | None = None):
        self.settings = settings or Settings.of()
        self.plan = plan or start_plan(self.settings)
        self.bus = Bus(
            types or TypeRegistry.default(), unregister_timeout=self.settings.bus.unregister_timeout
        )
        self.site = SiteUnit()  # a server with named robots: the site (its folder, nodes)
        self.robots: list[RobotUnit] = []  # every robot: its backend and its nodes
        self.link = None  # the ZenohLink with --bus zenoh
        self.sessions: set[ClientSession] = set()
        self.heap = HeapTrim()  # memory a big client held, given back once it left
        self.pool = WorkerPool()  # big ops off the event loop; shut down by stop()
        self.foxglove = FoxgloveShared.for_bus(self.bus, self.pool)
        self.shared = Shared.for_options(self.settings.session, self.pool)
        # the wire protocols served: rosbridge by default, others by WebSocket subprotocol
        self.protocols = WireProtocols(self.new_session)
        self.protocols.register(FOXGLOVE_SUBPROTOCOLS, self.new_foxglove_session)
        self._session_options: SessionOptions | None = None  # with the start's secret and tag
        self._ws = None
        self._tcp: asyncio.Server | None = None
        self._tls: HandshakeGate | None = None
        self._downloads: Downloads | None = None  # recordings streamed from their files
        self._ws_console = False
        self.port: int | None = None
        self.tcp_port: int | None = None
        self._rosout: RosoutHandler | None = None
        self.recording: RecordingControl | None = None
        self.vda5050: Vda5050Service | None = None  # --vda5050: every robot a vehicle
        self.metrics = ServerMetrics(Sources(
            sessions=lambda: self.sessions, robots=lambda: self.robots, site=lambda: self.site,
            recording=lambda: self.recording, worker=self.plan.worker_id
            if self.plan.worker else None))
        self.black_box: BlackBoxControl | None = None
        self.replays: ReplayLauncher | None = None
        self.access = Access(self.settings.session.authenticate)  # made at start (files read)
        self.whoami = WhoAmI(self.bus, lambda: self.access)

    def _options(self) -> SessionOptions:
        return self._session_options or self.settings.session.for_sessions()

    def _track(self, session: T) -> T:
        """Keep a new session until it closes (stop closes those left); its outbox counts
        into the metrics."""
        session.outbox.traffic = self.metrics.traffic
        self.sessions.add(session)
        session.on_close.append(self.sessions.discard)
        session.on_close.append(self.heap.client_left)
        return session

    def new_session(self, peer: str, transport: str, grant: Grant | None = None) -> Session:
        return self._track(Session(
            self.bus, self._options(), peer=peer, transport=transport, shared=self.shared,
            grant=grant))

    def new_foxglove_session(self, peer: str, subprotocol: str,
                             grant: Grant | None = None) -> FoxgloveSession:
        """A client that asked for a Foxglove subprotocol (PROTOCOL.md §18)."""
        return self._track(FoxgloveSession(
            self.bus, self._options(), self.foxglove, peer=peer, subprotocol=subprotocol,
            grant=grant))

    async def start(self) -> None:
        """Start everything; on a failure, stop what was started (the Zenoh session's threads
        would otherwise keep the process alive) and raise."""
        try:
            await self._start()
        except BaseException:
            try:
                await self.stop()
            except Exception:
                log.exception("stopping after a failed start")
            raise

    async def _start(self) -> None:
        s, plan = self.settings, self.plan
        secret = _secret(s.session)  # first: a missing secret is refused before anything starts
        self.access = access_of(s)  # and a bad roles file
        self.shared.access = self.foxglove.access = self.access
        warn_if_open(s)
        await self._start_recording()
        self.bus.taps.append(self.metrics.publishes)
        self.metrics.loop.start()
        self._rosout = RosoutHandler(self.bus, s.process.log_level.upper())
        logging.getLogger(PACKAGE_LOGGER).addHandler(self._rosout)
        tag = await self._start_link() if plan.zenoh else ""
        self._session_options = s.session.for_sessions(secret, tag)
        self.site, self.robots = await start_planned(self.bus, s, plan)
        vehicles = [VdaRobot(u.name, u.robot) for u in self.robots if u.robot is not None]
        if s.vda5050.vda5050 and vehicles:  # worker 0, which runs the robots
            self.vda5050 = Vda5050Service(self.bus, s.vda5050, vehicles,
                                          s.nodes.slamware.map_frame)
            await self.vda5050.start()
        if plan.warm_pool:  # spawned before the first client (after the robots' CPU-heavy
            self.pool.warm(*POOL_MODULES)  # start), warming in the background
        await self._start_listeners()
        if plan.worker and os.environ.get(METRICS_DIR):  # one scrape covers every worker
            await self.metrics.share(os.environ[METRICS_DIR])

    async def _start_recording(self) -> None:
        s = self.settings
        self.recording = RecordingControl(self.bus, s.store.recordings,
                                          topics=s.record.record_topics,
                                          split_size=s.record.split_bytes,
                                          split_time=s.record.split_seconds,
                                          max_disk=s.record.max_disk_bytes)
        if self.plan.record:  # first: an unwritable path is refused before anything starts
            self.recording.start_recording(self.plan.record)
        await self.recording.start()
        if self.plan.black_box:
            r = s.record
            self.black_box = BlackBoxControl(
                self.bus, s.store.recordings, seconds=r.black_box, max_bytes=r.black_box_bytes,
                topics=r.record_topics, localization_threshold=r.black_box_localization)
            await self.black_box.start()
        self.replays = ReplayLauncher(self.bus, s.store.recordings, s.transport.address,
                                      replay_access_flags(s))
        await self.replays.start()
        await self.whoami.start()

    async def _start_link(self) -> str:
        """Join the Zenoh network; the client tag that keeps this server's client node names
        apart from those of the other servers on it."""
        try:  # imported only when asked for: the default bus never loads Zenoh
            from .bus.zenoh.link import ZenohLink
        except ImportError as exc:
            raise ValueError(
                f"--bus zenoh needs the eclipse-zenoh package ({exc}); "
                "install it with: pip install 'hitrobot-server[zenoh]'"
            ) from None
        b = self.settings.bus
        self.link = ZenohLink(
            self.bus,
            domain=b.zenoh_domain,
            config_file=b.zenoh_config,
            connect=endpoints(b.zenoh_connect),
            listen=endpoints(b.zenoh_listen),
            shared_params=self.plan.worker,
        )
        await self.link.start()
        return f"{self.link.zid[:8]}_"

    async def _start_listeners(self) -> None:
        """The WebSocket port (with the web console) and the TCP port, as the plan says."""
        t, session, plan = self.settings.transport, self.settings.session, self.plan

        tls = self._tls = HandshakeGate(
            _tls_context(t), t.tls_handshake_timeout, t.max_tls_handshakes,
            t.max_tls_handshakes_per_address,
        ) if plan.tls else None
        console = _web_console()
        self._ws_console = console is not None
        pages = {LAYOUT_PATH: self.layout_page,  # topic names: any role's console
                 "/metrics": self.metrics.metrics_page, "/healthz": self.metrics.health_page}
        http_handler = WithRecordings(console, self.settings.store.recordings, pages,
                                      self.access)
        worker = {WORKER_HEADER: str(plan.worker_id)} if plan.worker else None
        self._downloads = Downloads(http_handler.resolve, (worker or {}).items(),
                                    self.access.http_refusal)
        self._ws = await start_websocket(
            self.protocols,
            t.address,
            t.port,
            max_frame_size=session.max_frame_size,
            delay_between_messages=t.delay_between_messages,
            compression=t.use_compression,
            http_handler=http_handler,
            tls=tls,
            ping_interval=t.websocket_ping_interval,
            ping_timeout=t.websocket_ping_timeout,
            reuse_port=plan.worker,
            headers=worker,
            downloads=self._downloads,
            send_window=t.send_window,
            access=self.access,
        )
        self.port = self._ws.sockets[0].getsockname()[1] if self._ws.sockets else t.port
        if plan.tcp:
            self._tcp = await start_tcp(
                self.protocols.default,
                t.address,
                t.tcp_port if t.tcp_port > 0 else 0,
                max_frame_size=session.max_frame_size,
                delay_between_messages=t.delay_between_messages,
                tls=tls,
                reuse_port=plan.worker,
            )
            self.tcp_port = self._tcp.sockets[0].getsockname()[1]
        log.info("hitrobot-server: ws://%s:%s tcp:%s", t.address, self.port, self.tcp_port)
        if self._ws_console:
            log.info("web console: %s", console_url(t.address, self.port, tls=t.ssl))

    async def layout_page(self) -> tuple[int, str, bytes]:
        """``GET /foxglove/layout.json``: a Foxglove layout of every robot's topics here."""
        named = [e.name for e in self.settings.robot_entries() if e.spec != "none"]
        found = foxglove_layout.layout(named, fleet=bool(self.settings.robots))
        return 200, "application/json", json.dumps(found, indent=1).encode() + b"\n"

    def banner(self) -> str:
        """The line printed once the server listens (tests and scripts parse it)."""
        address = self.settings.transport.address
        ws, tcp = self.settings.transport.schemes()
        return (f"hitrobot-server {__version__}: {ws}://{address}:{self.port}"
                + (f"  {tcp}://{address}:{self.tcp_port}" if self.tcp_port else ""))

    async def stop(self) -> None:
        if self._tls is not None:
            self._tls.close()
        if self._tcp is not None:
            self._tcp.close()
        if self._ws is not None:
            self._ws.close()
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._ws.wait_closed(), 5)
        if self._tcp is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._tcp.wait_closed(), 5)
        if self._downloads is not None:
            self._downloads.close()
        for session in list(self.sessions):
            session.close()
        self.heap.close()
        self.pool.shutdown()
        self.metrics.loop.stop()
        self.metrics.unshare()
        if self.black_box is not None:  # the robots stopping is no incident
            self.black_box.shutting_down()
        if self.vda5050 is not None:  # OFFLINE to the master before the robots go
            await self.vda5050.stop()
            self.vda5050 = None
        await stop_robots(self.site, self.robots)
        self.robots.clear()
        if self.black_box is not None:  # after the nodes, as the recording
            await self.black_box.stop()
            self.black_box = None
        if self.replays is not None:
            await self.replays.stop()
            self.replays = None
        self.whoami.stop()
        if self.recording is not None:  # after the nodes: their last messages are kept
            await self.recording.stop()
            self.recording = None
        if self._rosout is not None:
            logging.getLogger(PACKAGE_LOGGER).removeHandler(self._rosout)
            self._rosout.close()
            self._rosout = None
        await self._stop_link()

    @property
    def robot(self) -> Robot | None:
        """The first robot's capabilities (the single robot's), None without one: what tools
        and tests drive it through (its motion behind the locomotion gate)."""
        return self.robots[0].robot if self.robots else None

    @property
    def state(self) -> StateBinding:
        """The first robot's state folder (the single robot's), unbound without one."""
        return self.robots[0].state if self.robots else StateBinding()

    async def _stop_link(self) -> None:
        if self.link is not None:
            await self.link.stop()
            self.link = None


def _secret(options: SessionOptions) -> str | None:
    """The rosauth secret of ``--authenticate``, read from its file at start (None without
    the file: tokens only)."""
    if not options.authenticate or not options.auth_secret_file:
        return None
    return load_secret(options.auth_secret_file)


def access_of(settings: Settings) -> Access:
    """Tokens and roles as the settings say: the tokens file (``--tokens-file``, else
    STATE_DIR/tokens.json) read on use, the roles of ``--roles`` (a bad file refuses the
    start)."""
    s = settings.session
    roles = roles_from(Path(s.roles).read_text(encoding="utf-8")) if s.roles else RoleTable()
    if not s.authenticate:
        return Access(False, None, roles)
    path = Path(s.tokens_file) if s.tokens_file else tokens_path(settings.store.state_root)
    return Access(True, TokenBook(path).lookup, roles)


def replay_access_flags(settings: Settings) -> list[str]:
    """What a replay server (``/record/replay``) is started with so that it asks the same
    tokens as this one (it serves the site's recordings)."""
    s = settings.session
    if not s.authenticate:
        return []
    path = s.tokens_file or str(tokens_path(settings.store.state_root))
    return ["--authenticate", "--tokens-file", path, *(["--roles", s.roles] if s.roles else [])]


LOOPBACK = ("127.", "::1", "localhost")


def warn_if_open(settings: Settings) -> None:
    """Without ``--authenticate`` every client is admin: said loudly when the server listens
    beyond this machine."""
    address = settings.transport.address
    if settings.session.authenticate or address.startswith(LOOPBACK):
        return
    log.warning("listening on %s WITHOUT --authenticate: anyone who reaches this port can "
                "drive the robot, change its maps and shut it down (every client is admin). "
                "Make a token with 'hitrobot-server token add NAME --role operator' and start "
                "with --authenticate", address or "every address")


def _tls_context(options: TransportOptions) -> ssl.SSLContext:
    """The server side of TLS for ``--ssl``: the certificate chain and key from the files."""
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(options.certfile or "", options.keyfile)
    return context


def _web_console() -> StaticFiles | None:
    """The web console's files (``web/``), served by plain HTTP GET on the WebSocket port."""
    root = default_web_root()
    if root is None:
        log.warning("web console files not found; HTTP GET answers 426")
        return None
    if missing := missing_libraries(root):
        log.warning("the web console's libraries are missing (%s): the page cannot work; "
                    "run `npm ci --prefix web` in the checkout, then reinstall",
                    ", ".join(name.split("/")[1] for name in missing))
    return StaticFiles(root)


def console_url(address: str, port: int, *, tls: bool = False) -> str:
    """The console's address for the log: a wildcard bind is reachable on loopback too."""
    host = {"0.0.0.0": "127.0.0.1", "::": "::1", "": "127.0.0.1"}.get(address, address)
    scheme = "https" if tls else "http"
    return f"{scheme}://[{host}]:{port}/" if ":" in host else f"{scheme}://{host}:{port}/"

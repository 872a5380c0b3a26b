"""Assemble the bus, its nodes and the transports into one running server."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import ssl

from .bus.core import Bus
from .bus.rosout import RosoutHandler
from .config import Settings
from .nodes.assembly import restored_summary, start_nodes, stop_nodes
from .nodes.base import Node
from .protocol.auth import load_secret
from .robot.backend import BackendError
from .robot.factory import build_backend, sim_identity
from .session.options import SessionOptions
from .session.session import Session, Shared
from .state import StateBinding, StateStore, identity_folder
from .transport.http import StaticFiles, default_web_root, missing_libraries
from .transport.tcp import start_tcp
from .transport.websocket import start_websocket
from .types.registry import TypeRegistry

log = logging.getLogger(__name__)
PACKAGE_LOGGER = "hitrobot_server"  # every record of ours goes to /rosout too


class HitrobotServer:
    """The bridge: ``await start()``, read ``port``/``tcp_port``, ``await stop()``."""

    def __init__(self, settings: Settings | None = None, types: TypeRegistry | None = None):
        self.settings = settings or Settings()
        self.bus = Bus(
            types or TypeRegistry.default(), unregister_timeout=self.settings.unregister_timeout
        )
        self.nodes: list[Node] = []
        self.link = None  # the ZenohLink with --bus zenoh
        self.backend = None  # the robot (RobotBackend) when one is attached
        self.state = StateBinding()  # the robot's state folder, once its identity is known
        self._binder: asyncio.Task | None = None
        self.sessions: set[Session] = set()
        self.shared = Shared.for_options(self.settings.session_options())
        self._session_options: SessionOptions | None = None  # built at start
        self._ws = None
        self._tcp: asyncio.Server | None = None
        self._ws_console = False
        self.port: int | None = None
        self.tcp_port: int | None = None
        self._rosout: RosoutHandler | None = None

    def new_session(self, peer: str, transport: str) -> Session:
        if self._session_options is None:
            self._session_options = self.settings.session_options()
        session = Session(
            self.bus, self._session_options, peer=peer, transport=transport, shared=self.shared
        )
        self.sessions.add(session)
        session.on_close.append(self.sessions.discard)
        return session

    async def start(self) -> None:
        s = self.settings
        if s.authenticate:
            if not s.auth_secret_file:
                raise ValueError("--authenticate needs --auth-secret-file")
            s.auth_secret = load_secret(s.auth_secret_file)
        self._rosout = RosoutHandler(self.bus, s.log_level.upper())
        logging.getLogger(PACKAGE_LOGGER).addHandler(self._rosout)
        if s.bus == "zenoh":
            try:  # imported only when asked for: the default bus never loads Zenoh
                from .bus.zenoh_link import ZenohLink, endpoints
            except ImportError as exc:
                raise ValueError(
                    f"--bus zenoh needs the eclipse-zenoh package ({exc}); "
                    "install it with: pip install 'hitrobot-server[zenoh]'"
                ) from None

            self.link = ZenohLink(
                self.bus,
                domain=s.zenoh_domain,
                config_file=s.zenoh_config,
                connect=endpoints(s.zenoh_connect),
                listen=endpoints(s.zenoh_listen),
            )
            await self.link.start()
            s.client_tag = f"{self.link.zid[:8]}_"
        self._session_options = s.session_options()  # with the secret and client tag set
        robot = s.robot_options()
        if robot.robot == "sim":
            identity = sim_identity(robot)
            self.state = StateBinding(await open_state(s.state_root, identity, s.fresh), identity)
        self.backend = build_backend(robot, self.state.store)
        if self.backend is not None:
            await self.backend.start()
        self.nodes = await start_nodes(self.bus, s.node_options(), self.backend, self.state)
        if self.state.store is not None:
            report_restored(self.state.store, [*getattr(self.backend, "restored", []),
                                               *restored_summary(self.nodes)])
        elif self.backend is not None:  # a REST robot: its state folder once it says who it is
            self._binder = asyncio.ensure_future(self._bind_rest_state())

        def factory(peer: str, transport: str) -> Session:
            return self.new_session(peer, transport)

        tls = _tls_context(s) if s.ssl else None
        console = _web_console()
        self._ws_console = console is not None
        self._ws = await start_websocket(
            factory,
            s.address,
            s.port,
            max_frame_size=s.max_frame_size,
            delay_between_messages=s.delay_between_messages,
            compression=s.use_compression,
            http_handler=console,
            ssl=tls,
            ping_interval=s.websocket_ping_interval,
            ping_timeout=s.websocket_ping_timeout,
        )
        self.port = self._ws.sockets[0].getsockname()[1] if self._ws.sockets else s.port
        if s.tcp_port:
            self._tcp = await start_tcp(
                factory,
                s.address,
                s.tcp_port if s.tcp_port > 0 else 0,
                max_frame_size=s.max_frame_size,
                delay_between_messages=s.delay_between_messages,
                ssl=tls,
            )
            self.tcp_port = self._tcp.sockets[0].getsockname()[1]
        log.info("hitrobot-server: ws://%s:%s tcp:%s", s.address, self.port, self.tcp_port)
        if self._ws_console:
            log.info("web console: %s", console_url(s.address, self.port, tls=s.ssl))

    async def stop(self) -> None:
        if self._tcp is not None:
            self._tcp.close()
        if self._ws is not None:
            self._ws.close()
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._ws.wait_closed(), 5)
        if self._tcp is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._tcp.wait_closed(), 5)
        for session in list(self.sessions):
            session.close()
        if self._binder is not None:
            self._binder.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._binder
            self._binder = None
        await stop_nodes(self.nodes)
        self.nodes.clear()
        if self.backend is not None:
            await self.backend.stop()
            self.backend = None
        if self.state.store is not None:
            await self.state.store.close()
            self.state = StateBinding()
        if self._rosout is not None:
            logging.getLogger(PACKAGE_LOGGER).removeHandler(self._rosout)
            self._rosout.close()
            self._rosout = None
        if self.link is not None:
            await self.link.stop()
            self.link = None


    async def _bind_rest_state(self) -> None:
        """Whenever a REST robot (re)connects, and every few seconds while it is connected
        (a robot swapped at the same address may never look disconnected), ask who it is; a
        new identity gets its own state folder, and the log says which side's state won."""
        backend, binding = self.backend, self.state
        assert backend is not None
        loop = asyncio.get_running_loop()
        was, asked = False, -math.inf
        while True:
            now = backend.connected
            if now and (not was or loop.time() - asked >= IDENTITY_RECHECK):
                asked = loop.time()
                try:
                    info = await backend.get_device_info()
                except BackendError as exc:
                    log.warning("state: cannot ask the robot who it is (%s); retrying", exc)
                    now = False
                else:
                    identity = rest_identity(info.device_id, self.settings.robot)
                    if identity != binding.identity:
                        await self._bind(binding, identity)
                    elif not was:
                        log.info(
                            "state: robot %s reconnected: the robot's side stands for its map, "
                            "walls, tracks, home and pose (the server pushes none of them); the "
                            "server's side for its POIs, layers, routes and graphs, and its "
                            "masks are handed over again as the robot's blocked areas",
                            identity)
            was = now
            await asyncio.sleep(BIND_POLL)

    async def _bind(self, binding: StateBinding, identity: str) -> None:
        old, changed = binding.identity, binding.changed_unbound
        store = await open_state(self.settings.state_root, identity,
                                 self.settings.fresh and not old)
        if binding.store is not None:
            await binding.store.close()
        binding.store, binding.identity, binding.changed_unbound = store, identity, False
        nodes = [n for n in self.nodes if hasattr(n, "adopt")]
        if old:
            why = f"a different robot ({identity}, was {old}) answers at {self.settings.robot}"
            restore = True
        elif changed:
            why = ("the server's state was changed while the robot was not reached yet, so it is "
                   "newer than the folder's")
            restore = False
        else:
            why = "nothing was changed before the robot was reached"
            restore = True
        for node in nodes:
            node.adopt(restore)
        if restore:
            report_restored(store, restored_summary(self.nodes))
            log.info("state: the state folder won: %s", why)
        else:
            kept = await asyncio.to_thread(store.keep_copy, "superseded")
            store.restored.fresh, store.restored.summary = True, "nothing (the server's won)"
            log.info("state: the server's state won over %s: %s (the folder's state is kept "
                     "at %s)", store.path, why, kept)


BIND_POLL = 0.5
IDENTITY_RECHECK = 5.0
"""Seconds between asking a connected REST robot who it is (a swap keeps the address)."""


def rest_identity(device_id: str, url: str) -> str:
    """A REST robot's identity: its device id (serial), or its address if it gives none."""
    return f"slamware-{device_id}" if device_id else f"slamware-at-{url}"


async def open_state(root, identity: str, fresh: bool) -> StateStore:
    """One robot identity's state folder, read (off the event loop) before anything starts."""
    return await asyncio.to_thread(StateStore.open, identity_folder(root, identity), fresh)


def report_restored(store: StateStore, phrases: list[str]) -> None:
    """The start-up line: what came back and from where, or that the robot starts fresh."""
    restored = store.restored
    restored.fresh = not phrases
    restored.summary = ", ".join(phrases)
    if phrases:
        log.info("state: restored %s from %s", restored.summary, store.path)
    else:
        log.info("state: started fresh in %s", store.path)


def _tls_context(settings: Settings) -> ssl.SSLContext:
    """The server side of TLS for ``--ssl``: the certificate chain and key from the files."""
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(settings.certfile or "", settings.keyfile)
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

"""One session shape for every wire protocol: both sessions are ClientSessions, the transport
names neither, and the server's WireProtocols picks a session by subprotocol."""

from __future__ import annotations

import ast
from pathlib import Path

import hitrobot_server.transport as transport
from hitrobot_server.protocol.foxglove import SUBPROTOCOLS
from hitrobot_server.session.client import ClientSession, StreamSession, WireProtocols
from hitrobot_server.session.foxglove.session import FoxgloveSession
from hitrobot_server.session.foxglove.shared import FoxgloveShared
from hitrobot_server.session.options import SessionOptions
from hitrobot_server.session.rosbridge.session import Session

CONCRETE = ("hitrobot_server.session.rosbridge", "hitrobot_server.session.foxglove")


async def test_both_sessions_are_client_sessions(hub):
    rosbridge = Session(hub.bus, SessionOptions(), shared=hub.shared)
    foxglove = FoxgloveSession(hub.bus, SessionOptions(), FoxgloveShared.for_bus(hub.bus))
    try:
        assert isinstance(rosbridge, ClientSession)
        assert isinstance(foxglove, ClientSession)
        assert isinstance(rosbridge, StreamSession)  # raw TCP feeds it decoded ops
        assert not isinstance(foxglove, StreamSession)
    finally:
        rosbridge.close()
        foxglove.close()


def imported(source: str) -> set[str]:
    """Every module a source imports, absolute, as written relative to transport/."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level:  # from ..session.x: hitrobot_server.<...>
                base = "hitrobot_server" if node.level == 2 else "hitrobot_server.transport"
                found.add(f"{base}.{node.module}" if node.module else base)
                found.update(f"{base}.{node.module}.{a.name}" for a in node.names)
            elif node.module:
                found.add(node.module)
                found.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return found


def test_the_transport_imports_no_concrete_session():
    folder = Path(transport.__file__).parent
    for path in folder.glob("*.py"):
        names = imported(path.read_text(encoding="utf-8"))
        bad = {n for n in names if n.startswith(CONCRETE) or n.endswith(
            (".Session", ".FoxgloveSession"))}
        assert not bad, f"{path.name} imports {sorted(bad)}"


def test_the_checker_sees_a_concrete_import():
    assert imported("from ..session.rosbridge.session import Session\n") >= {
        "hitrobot_server.session.rosbridge.session"}
    assert imported("from ..session.foxglove import session\n") >= {
        "hitrobot_server.session.foxglove"}


def test_a_subprotocol_picks_its_registered_session():
    opened = []
    protocols = WireProtocols(lambda peer, how: opened.append(("default", peer, how)))
    protocols.register(SUBPROTOCOLS, lambda peer, how: opened.append(("foxglove", peer, how)))
    protocols.register(["third.v1"], lambda peer, how: opened.append(("third", peer, how)))
    assert protocols.choose(["x", "third.v1", "foxglove.websocket.v1"]) == "third.v1"
    assert protocols.choose(["x"]) is None
    protocols.open("a", protocols.choose(["foxglove.sdk.v1"]))
    protocols.open("b", protocols.choose(["third.v1"]))
    protocols.open("c", protocols.choose([]))
    protocols.open("d", None, "tcp")
    assert opened == [("foxglove", "a", "foxglove.sdk.v1"), ("third", "b", "third.v1"),
                      ("default", "c", "ws"), ("default", "d", "tcp")]


async def test_client_ids_are_per_server(hub):
    """Each server numbers its own clients (no process-wide counter)."""
    other = FoxgloveShared.for_bus(hub.bus)
    first = FoxgloveSession(hub.bus, SessionOptions(), FoxgloveShared.for_bus(hub.bus))
    second = FoxgloveSession(hub.bus, SessionOptions(), other)
    try:
        assert first.node == second.node == "/hitrobot_client_foxglove_1"
    finally:
        first.close()
        second.close()


def test_the_wire_protocols_do_not_import_each_other():
    """rosbridge and Foxglove share only what is at session/ top (client, outbox, offload,
    options)."""
    folder = Path(transport.__file__).parent.parent / "session"
    for package, other in (("rosbridge", "foxglove"), ("foxglove", "rosbridge")):
        for path in (folder / package).glob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.ImportFrom):
                    assert other not in (node.module or "").split("."), f"{package}/{path.name}"
                    assert other not in (a.name for a in node.names), f"{package}/{path.name}"


async def test_the_server_owns_its_worker_pool_and_shuts_it_down(server):
    """The pool is the server's (no process-wide one): its sessions share it, stop ends it."""
    assert server.shared.pool is server.pool
    assert await server.pool.run(abs, -3) == 3  # starts a worker
    await server.stop()
    assert server.pool._pool is None

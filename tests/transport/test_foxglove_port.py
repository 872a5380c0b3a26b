"""One port, two protocols: the WebSocket subprotocol picks Foxglove's, anything else (nothing,
or a subprotocol we do not speak) is the rosbridge protocol exactly as before; also over wss://,
and refused (with the reason) under --authenticate."""

from __future__ import annotations

import json
import ssl

from websockets.asyncio.client import connect

from hitrobot_server.protocol.foxglove import SUBPROTOCOLS
from hitrobot_server.session.client import WireProtocols
from tests.helpers import WsClient
from tests.transport.test_tls import cert  # noqa: F401  (the certificate fixture)


def choose_subprotocol(offered: list[str], foxglove: bool) -> str | None:
    """What the WebSocket transport agrees on with the server's wire protocols (Foxglove's
    registered when it is served)."""
    protocols = WireProtocols(default=lambda peer, transport: None)
    if foxglove:
        protocols.register(SUBPROTOCOLS, lambda peer, subprotocol: None)
    return protocols.choose(offered)


def test_the_first_offered_foxglove_subprotocol_wins():
    assert choose_subprotocol(["x", "foxglove.sdk.v1", "foxglove.websocket.v1"], True) == (
        "foxglove.sdk.v1")
    assert choose_subprotocol(["rosbridge"], True) is None
    assert choose_subprotocol([], True) is None
    assert choose_subprotocol(["foxglove.websocket.v1"], False) is None


async def first_json(ws) -> dict:
    for _ in range(50):  # binary time frames may come first
        frame = await ws.recv()
        if isinstance(frame, str):
            return json.loads(frame)
    raise AssertionError("no JSON frame")


async def test_subprotocol_selects_the_protocol(server):
    async with connect(f"ws://127.0.0.1:{server.port}",
                       subprotocols=["foxglove.websocket.v1"]) as ws:
        assert ws.subprotocol == "foxglove.websocket.v1"
        assert (await first_json(ws))["op"] == "serverInfo"
    for offered in (None, ["rosbridge"]):
        raw = await connect(f"ws://127.0.0.1:{server.port}", subprotocols=offered)
        assert raw.subprotocol is None
        ros = WsClient(raw)
        assert (await ros.call("/rosapi/get_time"))["result"] is True
        await ros.close()


async def test_foxglove_over_wss(make_server, cert):  # noqa: F811
    certfile, keyfile = cert
    server = await make_server(ssl=True, certfile=certfile, keyfile=keyfile)
    ctx = ssl.create_default_context(cafile=certfile)
    async with connect(f"wss://127.0.0.1:{server.port}", ssl=ctx,
                       subprotocols=["foxglove.websocket.v1"]) as ws:
        assert (await first_json(ws))["op"] == "serverInfo"
        assert (await first_json(ws))["op"] == "advertise"


async def test_authenticate_asks_foxglove_for_a_token_at_the_upgrade(make_server, tmp_path):
    """The Foxglove protocol has no auth op: with --authenticate its upgrade without a token is
    refused (401, with the reason), and one with a token in the URL is served (issue 47)."""
    from websockets.exceptions import InvalidStatus

    from hitrobot_server.state.tokens import add_token, tokens_path

    state = tmp_path / "state"
    token = add_token(tokens_path(state), "studio", "viewer", None)
    server = await make_server(authenticate=True, state_dir=str(state))
    try:
        async with connect(f"ws://127.0.0.1:{server.port}",
                           subprotocols=["foxglove.websocket.v1"]):
            raise AssertionError("served without a token")
    except InvalidStatus as exc:
        assert exc.response.status_code == 401
        assert b"token" in exc.response.body
    async with connect(f"ws://127.0.0.1:{server.port}/?token={token}",
                       subprotocols=["foxglove.websocket.v1"]) as ws:
        assert (await first_json(ws))["op"] == "serverInfo"

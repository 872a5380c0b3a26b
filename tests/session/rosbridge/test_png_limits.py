"""A ``png`` op whose header declares more pixels than the max message size is refused before
it is decoded; a normal png op still works and nobody else notices."""

from __future__ import annotations

import base64
import io

import pytest
from PIL import Image

from hitrobot_server.protocol import png
from tests.helpers import TcpClient, WsClient
from tests.witness import Witness

pytestmark = pytest.mark.hostile


def bomb(side: int) -> str:
    """A real PNG of ``side`` x ``side`` black RGB pixels: tiny compressed, large decoded."""
    out = io.BytesIO()
    Image.new("RGB", (side, side)).save(out, format="PNG")
    return base64.b64encode(out.getvalue()).decode()


async def test_png_bomb_is_refused_before_decoding(make_server):
    server = await make_server(max_frame_size=300_000)
    witness = await Witness.open(server.port)
    bad = await WsClient.open(server.port)
    data = bomb(2000)  # 12 MB of pixels in ~12 kB
    assert len(data) < 50_000
    await bad.send({"op": "png", "id": "b1", "data": data})
    status = await bad.expect(op="status", id="b1")
    assert status["level"] == "error"
    assert "2000x2000 pixels" in status["msg"] and "limit of 300000 bytes" in status["msg"]
    tcp = await TcpClient.open(server.tcp_port)
    await tcp.send({"op": "png", "id": "b2", "data": data})
    assert "2000x2000" in (await tcp.expect(op="status", id="b2"))["msg"]
    # a real png-compressed op under the limit still runs
    call = b'{"op":"call_service","id":"viapng","service":"/rosapi/get_time"}'
    await bad.send({"op": "png", "data": png.encode(call)})
    assert (await bad.expect(op="service_response", id="viapng"))["result"] is True
    await witness.check()
    await bad.close()
    await tcp.close()
    await witness.close()

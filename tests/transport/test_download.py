"""Recordings downloads streamed from the file (issue 37, item 2): a stalled downloader costs
little, ``Range`` is honoured, a full download is the file."""

from __future__ import annotations

import asyncio
import os

import pytest

from hitrobot_server.procmem import memory
from hitrobot_server.transport.download import byte_range, claims
from tests.helpers import ServerProcess, WsClient, round_trip
from tests.transport.test_http import http

SIZE = 64 * 1024 * 1024


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """A server whose recordings folder holds big.mcap (64 MiB of real bytes)."""
    folder = tmp_path_factory.mktemp("recordings")
    block = os.urandom(1024 * 1024)
    with open(folder / "big.mcap", "wb") as f:
        for i in range(SIZE // len(block)):
            f.write(bytes([i]) + block[1:])
    server = ServerProcess("--record-dir", str(folder))
    yield server, folder / "big.mcap"
    server.stop()


async def start_download(port: int) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    """A client that asks for the file, reads its head and first bytes, then stops reading."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port, limit=2**16)
    writer.write(f"GET /recordings/big.mcap HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
    await writer.drain()
    head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 10)
    assert head.startswith(b"HTTP/1.1 200 ") and f"Content-Length: {SIZE}".encode() in head
    await asyncio.wait_for(reader.readexactly(1024), 10)
    return reader, writer


async def test_stalled_downloaders_cost_little_and_others_are_served(served):
    server, _file = served
    witness = await WsClient.open(server.port)
    await round_trip(witness)
    before = memory(server.proc.pid).total
    stalled = [await start_download(server.port) for _ in range(10)]
    try:
        await round_trip(witness)  # the loop answers while they stall
        peak = 0
        for _ in range(5):  # a few samples of the whole server (every process)
            await round_trip(witness)
            peak = max(peak, memory(server.proc.pid).total)
        assert peak - before < 16 * 1024 * 1024, (before, peak)  # the old way: +640 MB
    finally:
        for _reader, writer in stalled:
            writer.close()
        await witness.close()


async def test_range_and_head(served):
    server, file = served
    data = file.read_bytes()
    status, headers, body = await http(server.port, "GET", "/recordings/big.mcap",
                                       {"Range": "bytes=5000000-5000999"})
    assert status == 206 and body == data[5000000:5001000]
    assert headers["content-range"] == f"bytes 5000000-5000999/{SIZE}"
    assert headers["accept-ranges"] == "bytes" and headers["content-length"] == "1000"
    status, headers, body = await http(server.port, "GET", "/recordings/big.mcap",
                                       {"Range": "bytes=-10"})
    assert status == 206 and body == data[-10:]
    status, headers, _ = await http(server.port, "GET", "/recordings/big.mcap",
                                    {"Range": f"bytes={SIZE}-"})
    assert status == 416 and headers["content-range"] == f"bytes */{SIZE}"
    status, headers, body = await http(server.port, "HEAD", "/recordings/big.mcap")
    assert status == 200 and body == b"" and headers["content-length"] == str(SIZE)
    assert headers["accept-ranges"] == "bytes" and "attachment" in headers["content-disposition"]


async def test_a_full_download_is_the_file(served):
    server, file = served
    status, headers, body = await http(server.port, "GET", "/recordings/big.mcap")
    assert status == 200 and len(body) == SIZE and body == file.read_bytes()
    assert headers["content-type"] == "application/octet-stream"


async def test_a_bad_or_slow_request_head_is_refused(served):
    server, _file = served
    reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
    writer.write(b"GET /recordings/big.mcap HTTP/1.1\r\n" + b"X: " + b"y" * 20000 + b"\r\n\r\n")
    await writer.drain()
    assert await asyncio.wait_for(reader.read(), 10) == b""  # over the head's limit: closed
    writer.close()
    status, _h, _b = await http(server.port, "GET", "/recordings/big.mcap HTTP/1.1 extra")
    assert status == 400


def test_what_a_download_is_and_its_ranges():
    assert claims(b"GET /rec") is None and claims(b"GET /recordings/x") is True
    assert claims(b"GET / HTTP/1.1") is False and claims(b"HEAD /recordings/") is True
    assert byte_range("bytes=0-9", 100) == (0, 9) and byte_range("bytes=90-", 100) == (90, 99)
    assert byte_range("bytes=95-200", 100) == (95, 99) and byte_range("bytes=-5", 100) == (95, 99)
    assert byte_range("bytes=100-", 100) is False and byte_range("bytes=5-1", 100) is False
    assert byte_range("bytes=0-1,5-6", 100) is None and byte_range("items=0-1", 100) is None

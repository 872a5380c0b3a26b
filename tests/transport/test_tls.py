"""--ssl: wss:// and TLS on the TCP port with a real certificate; WebSocket pings drop a peer
that does not answer; rosbridge's parameter spellings on the command line."""

from __future__ import annotations

import asyncio
import base64
import datetime
import ipaddress
import os
import ssl

import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID
from websockets.asyncio.client import connect

from hitrobot_server.cli import build_parser
from hitrobot_server.config import load
from tests.helpers import TcpClient, WsClient, until
from tests.witness import Witness


@pytest.fixture(scope="module")
def cert(tmp_path_factory) -> tuple[str, str]:
    """A self-signed certificate for 127.0.0.1 and its key, as PEM files."""
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "127.0.0.1")])
    now = datetime.datetime.now(datetime.UTC)
    certificate = (
        x509.CertificateBuilder()
        .subject_name(name).issuer_name(name).public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=1))
        .add_extension(x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address(
            "127.0.0.1"))]), critical=False)
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .sign(key, hashes.SHA256())
    )
    folder = tmp_path_factory.mktemp("tls")
    certfile, keyfile = folder / "cert.pem", folder / "key.pem"
    certfile.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
    keyfile.write_bytes(key.private_bytes(serialization.Encoding.PEM,
                                          serialization.PrivateFormat.PKCS8,
                                          serialization.NoEncryption()))
    return str(certfile), str(keyfile)


async def test_wss_and_tls_tcp(make_server, cert):
    certfile, keyfile = cert
    server = await make_server(ssl=True, certfile=certfile, keyfile=keyfile)
    client_ctx = ssl.create_default_context(cafile=certfile)
    ws = WsClient(await connect(f"wss://127.0.0.1:{server.port}", ssl=client_ctx))
    assert (await ws.call("/rosapi/get_time"))["result"] is True
    reader, writer = await asyncio.open_connection("127.0.0.1", server.tcp_port, ssl=client_ctx)
    tcp = TcpClient(reader, writer)
    await tcp.send({"op": "call_service", "id": "tls", "service": "/rosapi/get_time"})
    assert (await tcp.expect(op="service_response", id="tls"))["result"] is True
    # plain text to a TLS port gets nowhere
    with pytest.raises(Exception):  # noqa: B017 - the handshake fails in a version-specific way
        async with asyncio.timeout(5):
            await WsClient.open(server.port)
    await ws.close()
    await tcp.close()


async def test_a_client_that_does_not_answer_pings_is_dropped(make_server):
    server = await make_server(websocket_ping_interval=0.2, websocket_ping_timeout=0.3)
    witness = await WsClient.open(server.port)  # answers pings (the websockets client does)
    reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
    key = base64.b64encode(os.urandom(16)).decode()
    writer.write((f"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 5)
    assert head.startswith(b"HTTP/1.1 101")
    first = await asyncio.wait_for(reader.readexactly(2), 5)
    assert first[0] & 0x0F == 0x9  # the server pings ...
    rest = await asyncio.wait_for(reader.read(), 10)  # ... and, unanswered, closes
    assert rest is not None and reader.at_eof()
    assert (await witness.call("/rosapi/get_time"))["result"] is True
    await witness.close()
    writer.close()


def test_rosbridge_parameter_spellings_are_accepted():
    args = build_parser().parse_args([
        "--fragment_timeout", "5", "--max_message_size", "100", "--delay_between_messages",
        "0.1", "--default_call_service_timeout", "3", "--websocket_ping_interval", "2",
        "--websocket-ping-timeout", "4", "--unregister_timeout", "1", "--topics_glob", "/a/*",
        "--use_compression", "--send_buffer_limit", "1000", "--fragment_memory_limit", "9"])
    s = load(args)
    session, transport = s.session, s.transport
    assert (session.fragment_timeout, session.max_message_size,
            transport.delay_between_messages) == (5, 100, 0.1)
    assert (session.call_service_timeout, transport.websocket_ping_interval,
            transport.websocket_ping_timeout) == (3, 2, 4)
    assert (s.bus.unregister_timeout, session.topics_glob, transport.use_compression) == \
        (1, "/a/*", True)
    assert (session.send_buffer_limit, session.fragment_memory_limit) == (1000, 9)
    with pytest.raises(ValueError, match="--certfile"):
        load(build_parser().parse_args(["--ssl"]))


async def idle(port: int, source: str) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    """A TCP connection from ``source`` that never starts its TLS handshake."""
    return await asyncio.open_connection("127.0.0.1", port, local_addr=(source, 0))


async def closed_by_server(reader: asyncio.StreamReader, timeout: float = 5.0) -> bool:
    try:
        return await asyncio.wait_for(reader.read(1), timeout) == b""
    except TimeoutError:  # (an OSError too): still open
        return False
    except (ConnectionError, OSError):
        return True


async def capped_server(make_server, cert, handshake_timeout: float):
    """A TLS server allowing 4 handshakes in progress, 2 from one address."""
    certfile, keyfile = cert
    return await make_server(ssl=True, certfile=certfile, keyfile=keyfile,
                             tls_handshake_timeout=handshake_timeout, max_tls_handshakes=4,
                             max_tls_handshakes_per_address=2)


async def test_handshakes_in_progress_are_capped_and_time_out(make_server, cert):
    certfile, _keyfile = cert
    server = await capped_server(make_server, cert, handshake_timeout=3)
    gate = server._tls
    client_ctx = ssl.create_default_context(cafile=certfile)

    async def wss() -> WsClient:
        return WsClient(await connect(f"wss://127.0.0.1:{server.port}", ssl=client_ctx))

    witness = await Witness.on(await wss(), await wss())  # connected before the flood
    # the flood: 30 connections from 5 source addresses, on both ports, none says a word
    flood = [await idle(port, f"127.0.0.{1 + i % 5}")
             for i in range(30) for port in (server.port, server.tcp_port)][:30]
    await until(lambda: gate.in_progress == 4, "4 handshakes in progress")
    closed = await asyncio.gather(*(closed_by_server(r, timeout=1.0) for r, _w in flood))
    assert closed.count(False) == 4 and gate.in_progress == 4  # the rest closed at once
    await witness.check()
    with pytest.raises(Exception):  # noqa: B017 - no place for a new handshake: closed
        async with asyncio.timeout(5):
            await wss()
    # the handshake timeout frees every place, on both ports
    for (reader, _writer), was_closed in zip(flood, closed, strict=True):
        if not was_closed:
            assert await closed_by_server(reader, timeout=10)
    await until(lambda: gate.in_progress == 0, "no handshake in progress", timeout=5)
    late = await wss()
    assert (await late.call("/rosapi/get_time"))["result"] is True
    reader, writer = await asyncio.open_connection("127.0.0.1", server.tcp_port, ssl=client_ctx)
    tcp = TcpClient(reader, writer)
    await tcp.send({"op": "call_service", "id": "tls", "service": "/rosapi/get_time"})
    assert (await tcp.expect(op="service_response", id="tls"))["result"] is True
    await witness.check()
    for _reader, w in flood:
        w.close()
    await tcp.close()
    await late.close()
    await witness.close()


async def test_one_source_address_cannot_take_every_place(make_server, cert):
    certfile, _keyfile = cert
    server = await capped_server(make_server, cert, handshake_timeout=30)
    gate = server._tls
    hog = [await idle(server.port, "127.0.0.7") for _ in range(2)]
    await until(lambda: gate.in_progress == 2, "2 handshakes in progress")
    third = await idle(server.tcp_port, "127.0.0.7")
    assert await closed_by_server(third[0])
    # another address still gets in, with a real TLS client
    client_ctx = ssl.create_default_context(cafile=certfile)
    reader, writer = await asyncio.open_connection("127.0.0.1", server.tcp_port, ssl=client_ctx,
                                                   local_addr=("127.0.0.8", 0))
    tcp = TcpClient(reader, writer)
    await tcp.send({"op": "call_service", "id": "other", "service": "/rosapi/get_time"})
    assert (await tcp.expect(op="service_response", id="other"))["result"] is True
    assert gate.in_progress == 2
    for _reader, w in [*hog, third]:
        w.close()
    await tcp.close()

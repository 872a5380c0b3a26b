"""What hostile clients can make the server hold, and how the others fare meanwhile.

Starts ``hitrobot-server`` (no robot; ``--ssl`` with a throw-away certificate for the TLS part)
as a separate process and replays issue 27's attacks at bench scale: calls to a provider that
never answers, parameters too big or too deep, ``fragment_size: 1``, a CBOR typed-array bomb
and TLS handshakes that never finish. For each it prints the server's resident memory
(server + worker processes, from /proc) before, at its peak and after the attacker left, and
the round trips of a witness client calling ``/rosapi/get_time`` meanwhile. Prints figures;
asserts nothing. Loopback only; every loop is bounded in count and time.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import datetime
import ipaddress
import json
import re
import ssl
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import cbor2
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID
from websockets.asyncio.client import connect

from hitrobot_server import procmem

MB = 2**20


class Server:
    """``python -m hitrobot_server`` on ephemeral loopback ports, its output drained."""

    def __init__(self, *args: str):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "-1",
             "--address", "127.0.0.1", "--robot", "none", "--log-level", "warning", *args],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            m = re.search(r"wss?://[\d.]+:(\d+)", line)
            if m:
                self.port = int(m.group(1))
                break
            if not line:
                raise RuntimeError("server did not start")
        threading.Thread(target=self.proc.stdout.read, daemon=True).start()

    def mem(self) -> float:
        return procmem.memory(self.proc.pid).total / MB

    def peak(self) -> float:
        pids = [self.proc.pid, *procmem.children(self.proc.pid)]
        return sum(procmem.peak_bytes(pid) for pid in pids) / MB

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


class Witness:
    """Calls ``/rosapi/get_time`` back to back and records each round trip."""

    def __init__(self, ws):
        self.ws = ws
        self.rtts: list[float] = []
        self._task = asyncio.ensure_future(self._run())

    async def _run(self) -> None:
        for i in range(1_000_000):
            t0 = time.perf_counter()
            await self.ws.send(json.dumps({"op": "call_service", "id": f"w{i}",
                                           "service": "/rosapi/get_time"}))
            while f'"w{i}"' not in await self.ws.recv():
                pass
            self.rtts.append(time.perf_counter() - t0)
            await asyncio.sleep(0.005)

    def window(self) -> str:
        got, self.rtts = self.rtts, []
        if not got:
            return "no answer"
        return f"p50 {1e3 * statistics.median(got):.1f} ms, max {1e3 * max(got):.0f} ms"

    async def close(self) -> None:
        self._task.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await self._task
        await self.ws.close()


async def until_text(ws, needle: str, timeout: float = 60.0) -> int:
    """Read frames until one holds ``needle``; returns how many were read."""
    count = 0
    async with asyncio.timeout(timeout):
        while True:
            frame = await ws.recv()
            count += 1
            if needle in (frame if isinstance(frame, str) else frame.decode("latin-1")):
                return count


def row(name: str, before: float, peak: float, after: float, note: str, witness: str) -> None:
    print(f"  {name:<34} {before:7.0f} {peak:7.0f} {after:7.0f}  {witness:<26} {note}")


async def pending_calls(server: Server, count: int) -> None:
    url = f"ws://127.0.0.1:{server.port}"
    async with connect(url) as provider, connect(url) as w, connect(url, max_size=None) as bad:
        await provider.send(json.dumps({"op": "advertise_service", "service": "/mute",
                                        "type": "std_srvs/Trigger"}))
        witness = Witness(w)
        await asyncio.sleep(0.2)
        witness.window()
        before = server.mem()
        for i in range(count):
            await bad.send(json.dumps({"op": "call_service", "id": f"c{i}",
                                       "service": "/mute"}))
        await bad.send(json.dumps({"op": "call_service", "id": "end",
                                   "service": "/rosapi/get_time"}))
        await until_text(bad, '"end"')
        peak = server.mem()
        await bad.close()
        await asyncio.sleep(0.5)
        row(f"{count:,} calls, never answered", before, peak, server.mem(),
            "in flight capped at 1000 (default); the rest refused", witness.window())
        await witness.close()
        provider.transport.abort()


async def parameters(server: Server) -> None:
    url = f"ws://127.0.0.1:{server.port}"
    async with connect(url) as w, connect(url, max_size=None) as bad:
        witness = Witness(w)
        await asyncio.sleep(0.2)
        witness.window()
        for name, text in (("24 MB value [[],[],...]", "[" + "[]," * 8_000_000 + "[]]"),
                           ("1 MB value [[],[],...] (accepted)", "[" + "[]," * 333_000 + "[]]"),
                           ("value nested 1000 deep", "[" * 1000 + "]" * 1000)):
            before = server.mem()
            t0 = time.perf_counter()
            await bad.send(json.dumps({"op": "call_service", "id": "p",
                                       "service": "/rosapi/set_param",
                                       "args": {"name": "/hostile", "value": text}}))
            await until_text(bad, '"service_response"')
            took = time.perf_counter() - t0
            t0 = time.perf_counter()
            await bad.send(json.dumps({"op": "call_service", "id": "g",
                                       "service": "/rosapi/get_param", "args": {"name": "/"}}))
            await until_text(bad, '"service_response"')
            row(name, before, server.mem(), server.mem(),
                f"set {1e3 * took:.0f} ms, get_param('/') {1e3 * (time.perf_counter() - t0):.0f}"
                " ms", witness.window())
        await witness.close()


async def fragments(server: Server) -> None:
    url = f"ws://127.0.0.1:{server.port}"
    async with connect(url) as w, connect(url, max_size=None) as pub, \
            connect(url, max_size=None) as sub:
        witness = Witness(w)
        await sub.send(json.dumps({"op": "subscribe", "topic": "/big", "type": "std_msgs/String",
                                   "fragment_size": 1}))
        await pub.send(json.dumps({"op": "advertise", "topic": "/big",
                                   "type": "std_msgs/String"}))
        await asyncio.sleep(0.3)
        witness.window()
        before = server.mem()
        t0 = time.perf_counter()
        await pub.send(json.dumps({"op": "publish", "topic": "/big",
                                   "msg": {"data": "x" * 365_000}}))
        first = json.loads(await sub.recv())
        frames = 1 + await until_text(sub, f'"num":{first["total"] - 1},')
        row("365 kB message, fragment_size 1", before, server.peak(), server.mem(),
            f"{frames} frames in {1e3 * (time.perf_counter() - t0):.0f} ms (was 364,941)",
            witness.window())
        await witness.close()


async def cbor_bomb(server: Server, size: int) -> None:
    url = f"ws://127.0.0.1:{server.port}"
    async with connect(url) as w, connect(url, max_size=None) as bad:
        witness = Witness(w)
        await bad.send(json.dumps({"op": "advertise", "topic": "/arr",
                                   "type": "std_msgs/Int8MultiArray"}))
        await bad.send(cbor2.dumps({"op": "publish", "topic": "/arr",
                                    "msg": {"data": cbor2.CBORTag(72, b"\1" * 300_000)}}))
        await bad.send(json.dumps({"op": "call_service", "id": "warm",
                                   "service": "/rosapi/get_time"}))
        await until_text(bad, '"warm"')  # the worker pool is up
        witness.window()
        before, peak0 = server.mem(), server.peak()
        await bad.send(cbor2.dumps({"op": "publish", "topic": "/arr",
                                    "msg": {"data": cbor2.CBORTag(72, b"\x80" * size)}}))
        await bad.send(json.dumps({"op": "call_service", "id": "done",
                                   "service": "/rosapi/get_time"}))
        await until_text(bad, '"done"')
        grown = server.peak() - peak0
        row(f"CBOR tag 72 over {size // MB} MB", before, before + grown, server.mem(),
            f"peak +{grown:.0f} MB ({grown * MB / size:.1f}x; was 56x)", witness.window())
        await witness.close()


def certificate(folder: Path) -> tuple[str, str]:
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "127.0.0.1")])
    now = datetime.datetime.now(datetime.UTC)
    cert = (x509.CertificateBuilder().subject_name(name).issuer_name(name)
            .public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(x509.SubjectAlternativeName(
                [x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]), critical=False)
            .sign(key, hashes.SHA256()))
    certfile, keyfile = folder / "cert.pem", folder / "key.pem"
    certfile.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    keyfile.write_bytes(key.private_bytes(serialization.Encoding.PEM,
                                          serialization.PrivateFormat.PKCS8,
                                          serialization.NoEncryption()))
    return str(certfile), str(keyfile)


async def tls_flood(count: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        certfile, keyfile = certificate(Path(tmp))
        server = Server("--ssl", "--certfile", certfile, "--keyfile", keyfile)
        try:
            ctx = ssl.create_default_context(cafile=certfile)
            async with connect(f"wss://127.0.0.1:{server.port}", ssl=ctx) as w:
                witness = Witness(w)
                await asyncio.sleep(0.2)
                witness.window()
                before = server.mem()
                conns = []
                for i in range(count):  # spread over 8 loopback source addresses
                    with contextlib.suppress(OSError):
                        conns.append(await asyncio.open_connection(
                            "127.0.0.1", server.port, local_addr=(f"127.0.0.{1 + i % 8}", 0)))
                await asyncio.sleep(0.5)
                peak = server.mem()
                opened = 0
                for reader, _writer in conns:
                    with contextlib.suppress(TimeoutError, OSError):
                        if await asyncio.wait_for(reader.read(1), 0.001) == b"":
                            continue
                    opened += 1
                for _reader, writer in conns:
                    writer.close()
                await asyncio.sleep(0.5)
                row(f"{count:,} TLS handshakes never finished", before, peak, server.mem(),
                    f"{opened} held (cap 64, 8 per address), the rest closed", witness.window())
                await witness.close()
        finally:
            server.stop()


async def main(quick: bool) -> None:
    print("hostile clients (issue 27): server + worker RSS in MB; witness = /rosapi/get_time "
          "round trips of another client meanwhile")
    print(f"  {'attack':<34} {'before':>7} {'peak':>7} {'after':>7}  {'witness':<26} note")
    attacks = [lambda s: pending_calls(s, 2_000 if quick else 10_000), parameters, fragments,
               lambda s: cbor_bomb(s, (8 if quick else 20) * MB)]
    for attack in attacks:  # each on a fresh server, so that its peak is its own
        server = Server()
        try:
            await attack(server)
        finally:
            server.stop()
    await tls_flood(300 if quick else 2_000)
    print("  (2 shared cores: timings are indicative only)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller attacks")
    asyncio.run(main(parser.parse_args().quick))

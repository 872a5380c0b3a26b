#!/usr/bin/env python3
"""Ceiling: the LaserScan fan-out of bench_fanout.py against a bare server that only
broadcasts the publish frames it is sent (no parsing), and the ratio of ours to it, by
delivered rate and by server CPU per message.

Runs ours and the ceiling interleaved (a busy machine's load falls on both alike). The bare
server is this file too (``--serve websockets|picows``), in its own process. Prints figures
only.

    .venv/bin/python bench/bench_ceiling.py --quick --clients 1
    .venv/bin/python bench/bench_ceiling.py --quick --ceiling-lib picows   # pip install picows
"""

from __future__ import annotations

import asyncio
import signal
import sys
from pathlib import Path

import orjson

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_fanout  # noqa: E402  (a sibling script, not a package)
from bench_fanout import Variant, fanout_table  # noqa: E402
from benchlib import (  # noqa: E402
    Config,
    ceiling_lib_flag,
    fnum,
    parser,
    run_main,
    table,
)
from wsclient import HOST  # noqa: E402


# ======================================================================= the bare servers
def picows_ceiling_main() -> None:
    """The same bare broadcast on picows (a Cython WebSocket layer), to see what a faster
    WebSocket layer would leave of the transport's share (issue 38 item 3). Not a dependency:
    ``pip install picows`` to run it."""
    from picows import WSListener, WSMsgType, ws_create_server

    subs: set = set()

    class Peer(WSListener):
        def on_ws_connected(self, transport) -> None:
            self.transport = transport

        def on_ws_frame(self, transport, frame) -> None:
            kind = frame.msg_type
            if kind == WSMsgType.TEXT:
                data = frame.get_payload_as_bytes()
                if data.startswith(b'{"op":"publish"'):
                    for peer in subs:
                        peer.transport.send(WSMsgType.TEXT, data)
                elif orjson.loads(data).get("op") == "subscribe":
                    subs.add(self)
            elif kind == WSMsgType.PING:
                transport.send_pong(frame.get_payload_as_bytes())
            elif kind == WSMsgType.CLOSE:
                transport.send_close(frame.get_close_code())
                transport.disconnect()

        def on_ws_disconnected(self, transport) -> None:
            subs.discard(self)

    async def main() -> None:
        server = await ws_create_server(lambda request: Peer(), HOST, 0)
        await serve_until_signalled(server)

    asyncio.run(main())


async def serve_until_signalled(server) -> None:
    """Print the ceiling's address (what ``start_ceiling`` waits for) and serve until
    SIGINT/SIGTERM."""
    port = server.sockets[0].getsockname()[1]
    print(f"ceiling ws://{HOST}:{port}", flush=True)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await stop.wait()


def ceiling_server_main() -> None:
    """A bare websockets server: subscribers register; every publish frame is broadcast
    unchanged (already-encoded JSON bytes, no parsing) to all subscribers."""
    from websockets.asyncio.server import broadcast, serve
    from websockets.exceptions import ConnectionClosed

    async def main() -> None:
        subs: set = set()

        async def handler(ws) -> None:
            try:
                while True:
                    frame = await ws.recv(decode=False)
                    if frame.startswith(b'{"op":"publish"'):
                        broadcast(subs, frame, text=True)
                    elif orjson.loads(frame).get("op") == "subscribe":
                        subs.add(ws)
            except ConnectionClosed:
                pass
            finally:
                subs.discard(ws)

        # the same transport settings as hitrobot_server/transport/websocket.py
        async with serve(
            handler, HOST, 0, max_size=None, compression=None, ping_interval=None, max_queue=64
        ) as server:
            await serve_until_signalled(server)

    asyncio.run(main())


# ======================================================================= the ratios
def ceiling_ratios(label: str, ours: list[dict], ceiling: list[dict]) -> list[str]:
    """Prints ``label``'s delivered rate and server CPU per message against the ceiling's;
    returns summary lines."""
    rows, lines = [], []
    for o, c in zip(ours, ceiling, strict=True):
        ratio = o["rate"] / c["rate"] if c["rate"] else float("nan")
        cpu_ratio = c["srv_us"] / o["srv_us"] if o["srv_us"] else float("nan")
        rows.append([o["clients"], fnum(o["rate"]), fnum(c["rate"]), f"{ratio:.2f}",
                     f"{o['srv_us']:.1f}", f"{c['srv_us']:.1f}", f"{cpu_ratio:.2f}",
                     f"{o['frame']:.0f}", f"{c['frame']:.0f}"])
        lines.append(f"{label}/ceiling {o['clients']:>2} clients: {ratio:.2f} "
                     f"({fnum(o['rate'])} vs {fnum(c['rate'])} msg/s); server CPU per message "
                     f"{o['srv_us']:.1f} vs {c['srv_us']:.1f} us, ratio {cpu_ratio:.2f}")
    print(f"\n  {label} vs ceiling (delivered msg/s, all clients)")
    print(table(["clients", label, "ceiling", "ratio", f"{label} srv us/msg",
                 "ceiling srv us/msg", "CPU ratio", f"{label} frame B", "ceiling frame B"],
                rows))
    print("  CPU ratio = ceiling's server CPU per delivered message / ours: the same "
          "comparison, less\n  sensitive to other load on the machine than the rate.")
    return lines


# ======================================================================= the scenario
async def fanout_and_ceiling(cfg: Config, ours: bool = True) -> list[str]:
    """Sections [2] (when ``ours``) and [4], their runs interleaved; the ratios when both ran.
    Returns the summary lines."""
    servers = bench_fanout.variants(cfg) if ours else []
    servers.append(Variant("ceiling", ceiling=True))
    runs = await bench_fanout.fanout_section(servers, cfg)
    lines = bench_fanout.report(servers, runs, cfg) if ours else []
    fanout_table(
        "\n[4] ceiling: the same LaserScan frames and counts, bare websockets server "
        "(broadcast() of the received\n    pre-encoded bytes, no parsing)",
        runs["ceiling"],
    )
    for v in servers:
        if not v.ceiling:
            lines += ceiling_ratios(v.label, runs[v.label], runs["ceiling"])
    return lines


def main() -> int:
    p = parser(__doc__.split("\n\n")[0], fanout=True)
    ceiling_lib_flag(p)
    p.add_argument("--serve", metavar="LIB", choices=("websockets", "picows"),
                   help="be the bare server (what the scenario starts in its own process)")
    args = p.parse_args()
    if args.serve:
        (picows_ceiling_main if args.serve == "picows" else ceiling_server_main)()
        return 0
    return run_main(args, fanout_and_ceiling)


if __name__ == "__main__":
    sys.exit(main())

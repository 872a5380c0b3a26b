"""``hitrobot-server replay FILE.mcap``: serve a recording on the bus with no robot, to every
rosbridge client and the console, until terminated (:mod:`hitrobot_server.record.player`)."""

from __future__ import annotations

import argparse
import asyncio
import sys

from ..config import add_arguments, load
from ..record.player import MAX_SPEED, Player
from ..record.reading import DEFAULT_MAX_INFLATED, load_recording
from ..robots import start_plan
from ..server import HitrobotServer
from ..signals import remove_parent_dir, started_by_a_server, until_stdin_closed, until_terminated
from ..types.registry import TypeRegistry
from . import run_command

PROG = "hitrobot-server replay"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Serve an MCAP recording (hitrobot-server --record, ROS 2 profile) on the "
        "bus instead of a robot: its topics in order with their recorded contents and stamps, "
        "latched ones latched; /replay/state and the services /replay/pause, /replay/resume, "
        "/replay/seek and /replay/set_speed control it (and Foxglove's timeline). It waits, "
        "paused, for the first client to subscribe to one of its topics. The server's clock is "
        "the recording's time. Every server flag applies.",
    )
    parser.add_argument("file", metavar="FILE", help="the recording (.mcap)")
    parser.add_argument("--speed", type=float, default=1.0,
                        help=f"recorded seconds per wall-clock second, up to {MAX_SPEED:g} "
                        "(default: 1)")
    parser.add_argument("--loop", action="store_true", help="start again at the end")
    parser.add_argument("--start", type=float, default=0.0, metavar="SECONDS",
                        help="begin this many seconds into the recording (default: 0)")
    parser.add_argument("--play", action="store_true",
                        help="play at once (default: paused until a client subscribes to one of "
                        "the recording's topics)")
    parser.add_argument("--max-inflated", type=int, default=DEFAULT_MAX_INFLATED >> 20,
                        metavar="MB", help="the most a replay may hold inflated at once (the "
                        "chunks it reads together) and inflate to index a file without an index; a "
                        "chunk that claims more is refused before it is inflated (default: "
                        f"{DEFAULT_MAX_INFLATED >> 20})")
    add_arguments(parser)
    return parser


async def serve(args: argparse.Namespace) -> None:
    settings = load(args)
    if args.robot not in (None, "none", ["none"]):  # --robot is repeatable: a list
        raise ValueError("replay serves the recording in place of a robot: --robot cannot be "
                         "used with it")
    if args.max_inflated <= 0:
        raise ValueError("--max-inflated must be above 0 MB")
    types = TypeRegistry()  # its own: the file's definitions may replace ours
    recording = await asyncio.to_thread(load_recording, args.file, types,
                                        args.max_inflated << 20)
    server = HitrobotServer(settings, types, plan=start_plan(settings, robot="none"))
    player = Player(server.bus, recording, speed=args.speed, loop=args.loop, start=args.start,
                    play=args.play)
    server.bus.clock = player.clock
    await server.start()
    orphaned = False
    try:
        await player.start()
        print(server.banner(), flush=True)
        cut = "" if recording.complete else " (cut off: served as far as it goes)"
        wait = "" if args.play else ", paused until a client subscribes"
        print(f"{PROG}: {recording.path.name}, {recording.duration:.1f} s, "
              f"{len(recording.messages)} messages on {len(recording.tracks)} topics{cut}{wait}",
              flush=True)
        if started_by_a_server():  # the console's replay: it ends with the live server
            orphaned = await _until_terminated_or_orphaned()
        else:
            await until_terminated()
    finally:
        await player.stop()
        await server.stop()
        recording.close()
    if orphaned:  # the live server died without removing this replay's folder
        remove_parent_dir()


async def _until_terminated_or_orphaned() -> bool:
    """Until SIGTERM/Ctrl-C (False) or the end of stdin, a pipe from the server that started
    this replay (True: that server is gone, however it died)."""
    stop = asyncio.ensure_future(until_terminated())
    gone = asyncio.ensure_future(until_stdin_closed())
    try:
        await asyncio.wait({stop, gone}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in (stop, gone):
            task.cancel()
    return gone.done() and not gone.cancelled()


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return run_command(PROG, lambda: serve(args), getattr(args, "log_level", None) or "info")


if __name__ == "__main__":
    sys.exit(main())

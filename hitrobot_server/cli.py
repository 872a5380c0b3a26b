"""``hitrobot-server`` command line: run the server, or a tool (``conformance``,
``sim-device``)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import sys

from . import __version__
from .commands import run_command
from .config import Settings, add_arguments, load
from .signals import remove_parent_dir, serve_until_terminated, until_stdin_closed

TOOLS = {
    "conformance": "hitrobot_server.conformance.runner",
    "sim-device": "hitrobot_server.commands.sim_device",
    "replay": "hitrobot_server.commands.replay",
    "token": "hitrobot_server.commands.tokens",
}

USAGE = """%(prog)s [options]
       %(prog)s conformance --url ws://HOST:PORT [options]
       %(prog)s sim-device [--port PORT] [options]
       %(prog)s replay FILE.mcap [--speed X] [--loop] [--start SECONDS] [--play] [options]
       %(prog)s token add NAME --role ROLE [--expires 30d] | list | revoke NAME [--state-dir DIR]"""


class HelpFormatter(argparse.HelpFormatter):
    """A flag's spellings, then its value once (``--tcp-port, --tcp_port TCP_PORT``), as
    Python 3.13 prints them, on every Python: the help reads the same everywhere."""

    def _format_action_invocation(self, action: argparse.Action) -> str:
        if not action.option_strings or action.nargs == 0:
            return super()._format_action_invocation(action)
        value = self._format_args(action, self._get_default_metavar_for_optional(action))
        return f"{', '.join(action.option_strings)} {value}"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hitrobot-server",
        usage=USAGE,
        formatter_class=HelpFormatter,
        description=(
            "A rosbridge-v2-compatible (hitrobot protocol) WebSocket and TCP server with an "
            "in-process topic/service/action bus. Tools: 'hitrobot-server conformance --url "
            "ws://HOST:PORT' runs the protocol conformance vectors against any server; "
            "'hitrobot-server sim-device --port 1448' serves the simulated robot over the "
            "Slamware REST API (for --robot http://127.0.0.1:1448); 'hitrobot-server replay "
            "FILE.mcap' serves a recording (--record) on the bus instead of a robot. Each tool's "
            "--help lists its options."
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    add_arguments(parser)
    return parser


async def serve(settings: Settings) -> None:
    from .server import HitrobotServer

    server = HitrobotServer(settings)
    loop = asyncio.get_running_loop()
    logging.getLogger(__name__).info("event loop: %s", type(loop).__module__.split(".")[0])
    orphaned = False

    async def parent_gone() -> None:
        nonlocal orphaned
        await until_stdin_closed()
        orphaned = True

    try:
        if settings.worker_id is None:
            await _run(server)
        else:  # one of --workers: also stop when the parent is gone, even while starting
            await _first(_run(server), parent_gone())
    finally:
        await server.stop()
        if orphaned:  # a kill -9'd parent left its folder (the workers' sockets) behind
            remove_parent_dir()


async def _run(server) -> None:
    """Start, say so (stdout, and systemd), serve until Ctrl-C/SIGTERM."""
    await server.start()
    print(server.banner(), flush=True)
    await serve_until_terminated(server.banner())


async def _first(*waits) -> None:
    """Until the first of ``waits`` ends (its error raised); the others are cancelled."""
    tasks = [asyncio.ensure_future(w) for w in waits]
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
    for task in done:
        task.result()


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in TOOLS:
        import importlib

        return importlib.import_module(TOOLS[argv[0]]).main(argv[1:])
    args = build_parser().parse_args(argv)
    try:
        settings = load(args)
    except (OSError, ValueError) as exc:
        print(f"hitrobot-server: {exc}", file=sys.stderr)
        return 2
    log_level = settings.process.log_level
    if settings.worker_id is None and settings.process.worker_count > 1:
        from .workers import supervise

        return run_command(
            "hitrobot-server", lambda: supervise(settings, argv), log_level, settings.event_loop,
        )
    tag = "" if settings.worker_id is None else f"[worker {settings.worker_id}]"
    return run_command(
        "hitrobot-server", lambda: serve(settings), log_level, settings.event_loop, tag
    )


if __name__ == "__main__":
    sys.exit(main())

"""``hitrobot-server`` command line: run the server, or a tool (``conformance``,
``sim-device``)."""

from __future__ import annotations

import argparse
import sys

from . import __version__
from .commands import run_command
from .config import Settings, add_arguments, load
from .signals import until_terminated

TOOLS = {
    "conformance": "hitrobot_server.conformance.runner",
    "sim-device": "hitrobot_server.commands.sim_device",
}

USAGE = """%(prog)s [options]
       %(prog)s conformance --url ws://HOST:PORT [options]
       %(prog)s sim-device [--port PORT] [options]"""


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
            "Slamware REST API (for --robot http://127.0.0.1:1448). Each tool's --help lists "
            "its options."
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    add_arguments(parser)
    return parser


async def serve(settings: Settings) -> None:
    from .server import HitrobotServer

    server = HitrobotServer(settings)
    await server.start()
    ws, tcp = ("wss", "tcp+tls") if settings.ssl else ("ws", "tcp")
    print(
        f"hitrobot-server {__version__}: {ws}://{settings.address}:{server.port}"
        + (f"  {tcp}://{settings.address}:{server.tcp_port}" if server.tcp_port else ""),
        flush=True,
    )
    try:
        await until_terminated()
    finally:
        await server.stop()


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
    return run_command("hitrobot-server", lambda: serve(settings), settings.log_level)


if __name__ == "__main__":
    sys.exit(main())

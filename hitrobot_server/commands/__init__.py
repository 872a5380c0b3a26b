"""The command-line tools besides the server itself (``hitrobot-server <tool> ...``), and how
every command runs: log the same way, report an OSError/ValueError as exit code 1."""

from __future__ import annotations

import asyncio
import logging
import sys
from collections.abc import Callable, Coroutine
from typing import Any

from ..signals import catch_termination

LOG_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


def loop_factory(event_loop: str = "auto") -> Callable[[], asyncio.AbstractEventLoop] | None:
    """uvloop's event loop when asked for, or by default when it is installed (the
    ``[uvloop]`` extra); None = asyncio's own."""
    if event_loop == "asyncio":
        return None
    try:
        import uvloop
    except ImportError:
        if event_loop == "uvloop":
            raise ValueError("--event-loop uvloop needs the uvloop package; install it with: "
                             "pip install 'hitrobot-server[uvloop]'") from None
        return None
    return uvloop.new_event_loop


async def _caught(main: Callable[[], Coroutine[Any, Any, None]]) -> None:
    """``main()`` with SIGINT/SIGTERM caught from its first step (:func:`catch_termination`)."""
    catch_termination()
    await main()


def run_command(prog: str, main: Callable[[], Coroutine[Any, Any, None]], log_level: str,
                event_loop: str = "asyncio", log_tag: str = "") -> int:
    """Run ``main()`` until it returns; the exit code of the command. ``log_tag`` goes in
    front of every log record (``[worker 1]``: which process of ``--workers`` said it)."""
    log_format = LOG_FORMAT.replace("%(name)s", f"{log_tag} %(name)s") if log_tag else LOG_FORMAT
    logging.basicConfig(level=log_level.upper(), format=log_format)
    try:
        with asyncio.Runner(loop_factory=loop_factory(event_loop)) as runner:
            runner.run(_caught(main))
    except (OSError, ValueError) as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    return 0

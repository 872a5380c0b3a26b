"""The command-line tools besides the server itself (``hitrobot-server <tool> ...``), and how
every command runs: log the same way, report an OSError/ValueError as exit code 1."""

from __future__ import annotations

import asyncio
import logging
import sys
from collections.abc import Callable, Coroutine
from typing import Any

LOG_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


def run_command(prog: str, main: Callable[[], Coroutine[Any, Any, None]], log_level: str) -> int:
    """Run ``main()`` until it returns; the exit code of the command."""
    logging.basicConfig(level=log_level.upper(), format=LOG_FORMAT)
    try:
        asyncio.run(main())
    except (OSError, ValueError) as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    return 0

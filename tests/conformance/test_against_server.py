"""Our CI runs the conformance vectors against our own server, through the real CLI."""

from __future__ import annotations

import asyncio
import re
import sys


async def test_conformance_runner_passes_100_percent(server):
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "hitrobot_server", "conformance",
        "--url", f"ws://127.0.0.1:{server.port}",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT,
    )
    out, _ = await asyncio.wait_for(proc.communicate(), 300)
    text = out.decode()
    summary = re.search(r"^(\d+) passed, (\d+) failed$", text, re.M)
    assert summary, text
    passed, failed = map(int, summary.groups())
    assert failed == 0 and passed >= 70, text
    assert proc.returncode == 0, text

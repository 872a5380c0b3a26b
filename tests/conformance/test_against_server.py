"""Our CI runs the conformance vectors against our own server: one test per vector, and once
through the real CLI (its table, summary and exit code)."""

from __future__ import annotations

import asyncio
import re
import sys

import pytest

from hitrobot_server.conformance.runner import default_vectors, load_cases, run_case

CASES = load_cases(default_vectors())


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
async def test_vector(server, case):
    result = await run_case(case, f"ws://127.0.0.1:{server.port}")
    assert result.passed, f"{case.source}: {result.detail}"


async def test_conformance_cli_passes_every_vector(server):
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
    assert failed == 0 and passed == len(CASES), text
    assert proc.returncode == 0, text

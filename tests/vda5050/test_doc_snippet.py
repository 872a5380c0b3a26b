"""The manual's master (docs/vda5050.md, "Trying it from Python") runs as
written against a real server and broker (only the port changed) and prints what the text
says."""

from __future__ import annotations

import asyncio
import re
import sys
from pathlib import Path

from tests.helpers import until

DOC = Path(__file__).resolve().parents[2] / "docs" / "vda5050.md"


def snippet() -> str:
    text = DOC.read_text()
    start = text.index("## Trying it from Python")
    return re.compile(r"```python\n(.*?)```", re.S).search(text, start).group(1)


async def test_the_documented_master_drives_the_robot(make_server, broker, tmp_path):
    server = await make_server(robot="sim", vda5050=broker.url)
    link = server.vda5050.links[0][1]
    await until(lambda: link.connected, "the vehicle connected", 10)
    script = tmp_path / "master.py"
    script.write_text(snippet().replace("1883", str(broker.port)))
    proc = await asyncio.create_subprocess_exec(
        sys.executable, str(script), stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.STDOUT)
    out, _ = await asyncio.wait_for(proc.communicate(), 60)
    assert proc.returncode == 0, out.decode()
    assert out.decode().strip() == "reached ahead errors: []", out.decode()

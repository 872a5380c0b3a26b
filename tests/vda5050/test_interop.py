"""A real master control nobody here wrote: vda-5050-lib's MasterController (VDA 5050 2.0.0,
its own schema validation on both ways), run by Node, drives the simulated robot through
mosquitto: an order of three nodes, a pause and resume, an order update, a cancel, an
initPosition; every state, connection, factsheet and visualization it reads passes its checks."""

from __future__ import annotations

import asyncio
import shutil
from pathlib import Path

import pytest

JS = Path(__file__).resolve().parents[1] / "js"
CHECKS = ["state_and_position", "connection_online", "factsheet_actions", "pause", "resume",
          "order_update", "three_nodes_driven", "cancel", "init_position",
          "no_validation_error", "read_every_topic"]


@pytest.fixture(scope="module")
def master_lib() -> Path:
    if shutil.which("node") is None or not (JS / "node_modules" / "vda-5050-lib").is_dir():
        raise RuntimeError("vda-5050-lib is not installed: run `npm ci --prefix tests/js` "
                           "(.ci/run does this)")
    return JS


async def run_master(script: Path, *args: str, timeout: float = 240.0) -> dict[str, str]:
    proc = await asyncio.create_subprocess_exec(
        "node", str(script), *args, stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.STDOUT, cwd=script.parent)
    try:
        out, _ = await asyncio.wait_for(proc.communicate(), timeout)
    except TimeoutError:
        proc.kill()
        await proc.wait()
        raise
    text = out.decode()
    report = {line.split(":")[0].split(" ", 1)[1]: line for line in text.splitlines()
              if line.startswith(("ok ", "fail "))}
    report["_all"] = text
    report["_rc"] = str(proc.returncode)
    return report


async def test_vda_5050_lib_master_drives_the_sim_robot(make_server, broker, master_lib):
    server = await make_server(robot="sim", vda5050=broker.url)
    assert server.vda5050 is not None
    report = await run_master(master_lib / "vda5050_master.mjs", broker.url, "hitrobot", "robot")
    for name in CHECKS:
        assert report.get(name, "").startswith("ok "), f"{name}: {report.get(name)}\n" \
            f"{report['_all']}"
    assert report["_rc"] == "0", report["_all"]

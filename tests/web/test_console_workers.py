"""The console behind ``--workers 2``: whichever worker serves the page (and its WebSocket), it
loads and shows the robot, which runs in worker 0."""

from __future__ import annotations

import pytest

from hitrobot_server.server import WORKER_HEADER
from tests.helpers import ServerProcess
from tests.web.conftest import READY

MAX_LOADS = 16  # page loads at most to be served by both workers


@pytest.fixture
def workers(tmp_path):
    server = ServerProcess("--workers", "2", "--log-level", "warning", "--sim-speed", "4",
                           "--map-dir", str(tmp_path / "maps"), robot="sim")
    yield server
    server.stop()


async def test_the_console_loads_from_either_worker(workers, browser):
    served: set[str] = set()
    for _ in range(MAX_LOADS):
        page = await browser.new_page()  # new connections: the kernel picks a worker each time
        errors: list[str] = []
        page.on("pageerror", lambda e, errors=errors: errors.append(str(e)))
        try:
            response = await page.goto(f"http://127.0.0.1:{workers.port}/")
            assert response is not None and response.status == 200
            worker = (await response.all_headers())[WORKER_HEADER.lower()]
            await page.wait_for_function(READY, timeout=30_000)  # map, pose, mode: worker 0's
            assert await page.text_content("#bridge-state .value") == "connected"
            assert errors == []
            served.add(worker)
        finally:
            await page.close()
        if served == {"0", "1"}:
            break
    assert served == {"0", "1"}

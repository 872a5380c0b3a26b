from __future__ import annotations

import pytest

from tests.sansio import Hub, SessionClient


@pytest.fixture
async def make_hub(tmp_path):
    """``await make_hub(**session_options)``: a bus with its bridge nodes and socket-less
    sessions on it (see tests/sansio.py); stopped after the test."""
    hubs: list[Hub] = []

    async def make(**options) -> Hub:
        hub = await Hub(tmp_path / "maps", **options).start()
        hubs.append(hub)
        return hub

    yield make
    for hub in hubs:
        await hub.stop()


@pytest.fixture
async def hub(make_hub) -> Hub:
    return await make_hub()


@pytest.fixture
def peer(hub) -> SessionClient:
    return hub.open()

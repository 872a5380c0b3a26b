"""Shared fixtures: the office world (loaded once) and a bounded sim-time runner."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from hitrobot_server.robot.sim.simulator import Simulator
from hitrobot_server.robot.sim.world import World, load_world


@pytest.fixture(scope="session")
def world() -> World:
    return load_world()


def _run_until(sim: Simulator, done: Callable[[], bool], seconds: float, dt: float = 0.05) -> bool:
    """Step ``sim`` until ``done()`` or ``seconds`` of simulated time pass; whether it got done."""
    for _ in range(round(seconds / dt)):
        sim.step(dt)
        if done():
            return True
    return False


@pytest.fixture
def run_until() -> Callable[..., bool]:
    return _run_until

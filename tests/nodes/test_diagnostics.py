"""``/diagnostics_agg`` with and without a robot, over real WebSockets."""

from __future__ import annotations

import pytest

from hitrobot_server.nodes.diagnostics import ERROR, OK, STALE, WARN
from tests.helpers import Watcher
from tests.nodes.robot_setup import RobotSetup


def by_name(msg: dict) -> dict[str, dict]:
    return {s["name"]: s for s in msg["status"]}


def values(status: dict) -> dict[str, str]:
    return {kv["key"]: kv["value"] for kv in status["values"]}


async def test_without_a_robot_only_the_bridge_is_reported(make_server):
    server = await make_server()
    w = await Watcher.open(server.port)
    other = await Watcher.open(server.port)
    await w.subscribe("/diagnostics_agg", "diagnostic_msgs/DiagnosticArray")
    msg = await w.next("/diagnostics_agg", timeout=3)
    got = by_name(msg)
    assert set(got) == {"/Bridge", "/Bridge/Clients", "/Bridge/Memory", "/Bridge/Slow links"}
    assert got["/Bridge/Slow links"]["level"] == OK and got["/Bridge/Slow links"]["values"] == []
    clients = got["/Bridge/Clients"]
    assert clients["level"] == OK and values(clients)["clients"] == "2"
    assert clients["message"] == "2 clients connected"
    assert int(values(clients)["topics"]) >= 1
    mem = values(got["/Bridge/Memory"])
    assert float(mem["total mb"]) == pytest.approx(
        float(mem["server mb"]) + float(mem["workers mb"]), abs=0.2)
    assert float(mem["server mb"]) > 10  # a running Python server holds more than this
    await other.close()
    await w.close()


ROBOT = RobotSetup(sim_speed=4.0, watch={"/diagnostics_agg": None},
                   ready=lambda w: w.latest("/diagnostics_agg"),
                   ready_what="a new message on /diagnostics_agg", ready_timeout=3)


async def test_robot_items_are_ok_at_start_and_follow_the_robot(robot, monkeypatch):
    server, w = robot.server, robot.w
    got = by_name(w.latest("/diagnostics_agg"))
    assert {"/Robot", "/Robot/Connection", "/Robot/Battery", "/Robot/Localization",
            "/Robot/Motion", "/Robot/Health", "/Bridge", "/Bridge/Clients"} <= set(got)
    assert got["/Robot"]["level"] == OK
    assert got["/Robot/Connection"]["hardware_id"]
    assert values(got["/Robot/Battery"])["charging"] == "false"
    assert got["/Robot/Motion"]["message"] == "idle"

    caps = server.robot
    quality = {"value": 40}

    async def fake_quality() -> int:
        return quality["value"]

    monkeypatch.setattr(caps.localization, "get_localization_quality", fake_quality)
    got = by_name(await w.next("/diagnostics_agg", timeout=3))
    assert got["/Robot/Localization"]["level"] == WARN
    assert got["/Robot"]["level"] == WARN
    quality["value"] = 20
    got = by_name(await w.next("/diagnostics_agg", timeout=3))
    assert got["/Robot/Localization"]["level"] == ERROR and got["/Robot"]["level"] == ERROR

    caps.simulator._battery.percentage = 10.0  # below Slamware's "power low"
    got = by_name(await w.next("/diagnostics_agg", timeout=3))
    assert got["/Robot/Battery"]["level"] == WARN and "low" in got["/Robot/Battery"]["message"]
    health = got["/Robot/Health"]
    assert health["level"] == WARN and "power low" in health["message"]


async def test_an_offline_robot_is_an_error_and_its_items_stale(robot):
    server, w = robot.server, robot.w
    await server.robot.link.stop()
    got = by_name(await w.next("/diagnostics_agg", timeout=3))
    assert got["/Robot/Connection"]["level"] == ERROR
    assert got["/Robot/Battery"]["level"] == STALE
    assert got["/Robot"]["level"] == ERROR
    assert got["/Bridge/Clients"]["level"] == OK

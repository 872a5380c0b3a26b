"""/rosout: log records as rosgraph_msgs/Log with node names, without feedback, bounded."""

from __future__ import annotations

import asyncio
import logging

import pytest

from hitrobot_server.bus import rosout
from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.rosout import RosoutHandler
from hitrobot_server.nodes.base import Node, RobotNode
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import until

log = logging.getLogger(__name__)


class Talker(Node):
    """A node defined in this module: this module's records are its records."""


@pytest.fixture
async def bus_and_log():
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    handler = RosoutHandler(bus, logging.INFO)
    log.addHandler(handler)
    log.setLevel(logging.DEBUG)
    got: list[dict] = []
    bus.subscribe(rosout.TOPIC, "rosgraph_msgs/Log", "watch", "/watcher",
                  lambda m: got.append(m.msg))
    yield bus, got
    log.removeHandler(handler)
    handler.close()


async def test_records_name_their_node_level_and_topics(bus_and_log):
    bus, got = bus_and_log
    talker = Talker(bus, "/talker")
    talker.advertise("/chatter", "std_msgs/String")
    log.warning("battery at %d%%", 12)
    log.debug("not at the configured level")
    await until(lambda: got, "a /rosout record")
    rec = got[0]
    assert rec["name"] == "/talker" and rec["level"] == 4 and rec["msg"] == "battery at 12%"
    assert rec["topics"] == ["/chatter"]
    assert rec["file"] == "test_rosout.py" and rec["function"].startswith("test_records")
    assert rec["header"]["stamp"]["secs"] > 1_600_000_000
    assert len(got) == 1
    assert bus.topic("/rosout").publishers and "/hitrobot_server" in bus.nodes
    talker.close()


async def test_errors_carry_the_traceback_and_other_loggers_are_the_server(bus_and_log):
    bus, got = bus_and_log
    try:
        raise ValueError("boom")
    except ValueError:
        log.exception("it failed")
    await until(lambda: got, "the error record")
    assert got[0]["level"] == 8 and "ValueError: boom" in got[0]["msg"]
    assert got[0]["name"] == rosout.SERVER_NODE  # no node registered this module here


async def test_logging_while_publishing_rosout_does_not_feed_back(bus_and_log):
    bus, got = bus_and_log

    def noisy(message) -> None:
        log.error("subscriber saw %s", message.msg["msg"])  # would loop forever if published

    bus.subscribe(rosout.TOPIC, None, "noisy", "/noisy", noisy)
    log.error("first")
    await until(lambda: got, "the first record")
    for _ in range(5):
        await asyncio.sleep(0)  # give a (wrong) feedback record every chance to be flushed
    assert [r["msg"] for r in got] == ["first"]


async def test_a_flood_is_bounded_and_reported(bus_and_log):
    bus, got = bus_and_log
    for i in range(rosout.BURST + 50):
        log.info("record %d", i)
    await until(lambda: len(got) >= rosout.BURST, "the burst")
    log.info("after")
    await until(lambda: any(r["msg"] == "after" for r in got), "the record after the flood")
    assert len(got) < rosout.BURST + 50
    reports = [r for r in got if "not published" in r["msg"]]
    assert reports and reports[0]["level"] == 4


async def test_shared_node_code_names_the_node_it_runs_for(bus_and_log):
    """A worker failing inside the nodes' shared base is reported as that node's record."""
    bus, got = bus_and_log
    base_log = logging.getLogger("hitrobot_server.nodes.base")
    handler = next(h for h in log.handlers if isinstance(h, RosoutHandler))
    base_log.addHandler(handler)
    try:
        worker = RobotNode(bus, "/worker", None)

        async def failing() -> None:
            raise RuntimeError("sensor gone")

        worker.every(0.01, failing, needs_robot=False)
        await until(lambda: got, "the worker's error")
        await worker.stop()
    finally:
        base_log.removeHandler(handler)
    assert got[0]["name"] == "/worker" and "sensor gone" in got[0]["msg"]

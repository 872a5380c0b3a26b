"""``GET /metrics`` (scraped with prometheus_client's own parser) and ``GET /healthz``
(issue 36, item 6)."""

from __future__ import annotations

import asyncio
import json

import pytest
from prometheus_client.parser import text_string_to_metric_families
from websockets.asyncio.client import connect

from hitrobot_server.session.traffic import MAX_TOPICS, OTHER_TOPICS
from tests.helpers import ServerProcess, WsClient, round_trip
from tests.test_process_tree import wait_for_line
from tests.transport.test_http import http
from tests.witness import MemoryPeak, RoundTrips


async def scrape(port: int) -> dict[str, dict[tuple, float]]:
    """name → {labels (sorted items): value}, parsed by prometheus_client."""
    status, headers, body = await http(port, "GET", "/metrics")
    assert status == 200 and headers["content-type"].startswith("text/plain; version=")
    samples: dict[str, dict[tuple, float]] = {}
    for family in text_string_to_metric_families(body.decode()):
        for sample in family.samples:
            samples.setdefault(sample.name, {})[tuple(sorted(sample.labels.items()))] = (
                sample.value)
    return samples


async def test_metrics_count_clients_topics_and_memory(make_server):
    server = await make_server(robot="sim")
    publisher = await WsClient.open(server.port)
    listener = await WsClient.open(server.port)
    try:
        await listener.send({"op": "subscribe", "topic": "/chatter", "type": "std_msgs/String"})
        await round_trip(listener)
        await publisher.send({"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
        for i in range(3):
            await publisher.send({"op": "publish", "topic": "/chatter", "msg": {"data": f"{i}"}})
        for _ in range(3):
            await listener.expect(op="publish", topic="/chatter")
        m = await scrape(server.port)
        clients = m["hitrobot_clients"]
        assert clients[(("protocol", "rosbridge"), ("transport", "ws"))] == 2
        assert clients[(("protocol", "foxglove"), ("transport", "ws"))] == 0
        chatter = (("topic", "/chatter"),)
        assert m["hitrobot_messages_received_total"][chatter] == 3
        assert m["hitrobot_received_bytes_total"][chatter] > 3 * len('"data"')
        assert m["hitrobot_messages_sent_total"][chatter] == 3
        assert m["hitrobot_sent_bytes_total"][chatter] > 0
        assert "hitrobot_messages_thinned_total" not in m or chatter not in m[
            "hitrobot_messages_thinned_total"]
        assert m["hitrobot_queued_bytes"][()] >= 0
        assert m["hitrobot_requests_in_flight"][()] == 0
        assert m["hitrobot_robot_link_up"][(("robot", "robot"),)] == 1
        assert m["hitrobot_state_write_failures_total"][(("robot", "robot"),)] == 0
        assert m["hitrobot_recording"][()] == 0 and m["hitrobot_recorder_dropped_total"][()] == 0
        rss = m["hitrobot_process_resident_bytes"]
        assert any(dict(k)["role"] == "server" and v > 10e6 for k, v in rss.items())
        assert 0 <= m["hitrobot_event_loop_lag_seconds"][()] < 2
    finally:
        await publisher.close()
        await listener.close()


async def test_received_bytes_grow_with_the_messages_nobody_subscribed_to(make_server):
    """Issue 46, friction 5: small publishes on a topic no client reads (a console's
    /cmd_vel) counted their messages but 0 bytes; each counts its op's length now."""
    server = await make_server(robot="sim")
    publisher = await WsClient.open(server.port)
    try:
        await publisher.send({"op": "advertise", "topic": "/lonely", "type": "std_msgs/String"})
        ops = [{"op": "publish", "topic": "/lonely", "msg": {"data": f"message {i}"}}
               for i in range(3)]
        for op in ops:
            await publisher.send(op)
        await round_trip(publisher)
        m = await scrape(server.port)
        lonely = (("topic", "/lonely"),)
        assert m["hitrobot_messages_received_total"][lonely] == 3
        sent = sum(len(json.dumps(op)) for op in ops)  # as the client sent them
        assert sent - 10 <= m["hitrobot_received_bytes_total"][lonely] <= sent + 20, m[
            "hitrobot_received_bytes_total"]
    finally:
        await publisher.close()


async def test_healthz_says_ok_and_what_it_checked(make_server):
    server = await make_server(robot="sim")
    status, headers, body = await http(server.port, "GET", "/healthz")
    assert status == 200 and headers["content-type"] == "application/json"
    health = json.loads(body)
    assert health["ok"] and health["loop"]["ok"]
    assert health["robots"]["links"] == [{"robot": "robot", "connected": True}]
    assert health["recorder"] == {"ok": True, "recording": False}
    assert health["state"]["ok"] and health["workers"]["ok"]


async def test_healthz_is_503_when_the_robot_does_not_answer(make_server):
    server = await make_server(robot="http://127.0.0.1:9")  # nobody listens there
    status, _headers, body = await http(server.port, "GET", "/healthz")
    health = json.loads(body)
    assert status == 503 and not health["ok"]
    assert health["robots"]["links"] == [{"robot": "robot", "connected": False}]
    m = await scrape(server.port)
    assert m["hitrobot_robot_link_up"][(("robot", "robot"),)] == 0


async def test_with_authenticate_served_to_a_token_that_may(make_server, tmp_path):
    """Issue 47: with --authenticate /metrics and /healthz answer a monitor's token (as a
    Bearer header), and 401 without one."""
    from hitrobot_server.state.tokens import add_token, tokens_path

    state = tmp_path / "state"
    token = add_token(tokens_path(state), "prometheus", "monitor", None)
    server = await make_server(authenticate=True, state_dir=str(state))
    for path in ("/metrics", "/healthz"):
        status, _h, body = await http(server.port, "GET", path)
        assert status == 401 and b"hitrobot_" not in body, path
        status, _h, body = await http(server.port, "GET", path,
                                      headers={"Authorization": f"Bearer {token}"})
        assert status == 200, (path, body)


async def test_one_scrape_covers_every_worker():
    """``--workers 2``: whichever worker answers, the scrape holds both workers' samples and
    the memory of every process (the parent, both workers)."""
    server = ServerProcess("--workers", "2")
    clients = []
    try:
        wait_for_line(server, "(2 workers)")
        seen: set[str] = set()
        for _ in range(60):  # a client on each worker (the kernel spreads connections)
            ws = await connect(f"ws://127.0.0.1:{server.port}")
            clients.append(ws)
            seen.add(ws.response.headers["X-Hitrobot-Worker"])
            if seen == {"0", "1"}:
                break
        assert seen == {"0", "1"}
        for _ in range(3):  # three scrapes, answered by either worker
            m = await scrape(server.port)
            per_worker = {dict(k)["worker"]: v for k, v in m["hitrobot_clients"].items()
                          if dict(k)["protocol"] == "rosbridge" and dict(k)["transport"] == "ws"}
            assert set(per_worker) == {"0", "1"} and sum(per_worker.values()) == len(clients)
            roles = {dict(k)["role"] for k in m["hitrobot_process_resident_bytes"]}
            assert {"supervisor", "worker 0", "worker 1"} <= roles
    finally:
        for ws in clients:
            await ws.close()
        server.stop()


NAMES = 10_000
"""Topic names clients published on (the per-topic counts keep 2,000 of them by name)."""
SCRAPES = 200


@pytest.mark.serial  # the witness's bound: run alone (tests/run.py)
async def test_a_scrape_storm_costs_the_other_clients_nothing():
    """Issue 52, item 6: 200 scrapes at once of a /metrics holding the bound of
    per-topic samples; the witness's round trips stay short and the memory comes back."""
    server = ServerProcess()
    try:
        publisher = await WsClient.open(server.port)
        for i in range(NAMES):
            topic = f"/storm/topic_with_a_long_name_{i:05d}"
            await publisher.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
            await publisher.send({"op": "publish", "topic": topic, "msg": {"data": "x"}})
        await round_trip(publisher, timeout=60)
        memory = MemoryPeak(server.proc.pid)
        first = await scrape(server.port)  # every publish counted (by name, or the others)
        assert len(first["hitrobot_messages_received_total"]) == MAX_TOPICS + 1
        assert first["hitrobot_messages_received_total"][(("topic", OTHER_TOPICS),)] == (
            NAMES - MAX_TOPICS)
        witness = await RoundTrips.open(server.port)
        pages = await asyncio.gather(*(http(server.port, "GET", "/metrics")
                                       for _ in range(SCRAPES)))
        assert all(status == 200 and len(body) > 100_000 for status, _, body in pages)
        worst = await witness.stop()
        after = memory.now() - memory.base
        memory.stop()
        await publisher.close()
        assert worst <= 0.5, witness.times
        assert after < 50_000_000, f"+{after / 1e6:.0f} MB after the storm"
    finally:
        server.stop()

"""``--workers 2`` for real: one parent, two worker processes behind the same ports, joined
over Zenoh. Clients land on both; everything answers the same from either; a killed worker
comes back."""

from __future__ import annotations

import asyncio
import os
import re
import signal
import ssl
import subprocess
import sys
import time
from pathlib import Path

import aiohttp
import pytest
from websockets.asyncio.client import connect

from hitrobot_server.server import WORKER_HEADER
from tests.bus.test_zenoh_scale_out import rosapi, until, until_listed
from tests.helpers import ServerProcess, TcpClient, WsClient, round_trip
from tests.helpers import until as until_true  # an in-process condition (the other: a round trip)
from tests.transport.test_tls import cert  # noqa: F401  (the self-signed certificate fixture)

MAX_TRIES = 64  # connections opened at most to find a given worker


@pytest.fixture(scope="module")
def workers():
    server = ServerProcess("--workers", "2", "--log-level", "warning")
    yield server
    server.stop()


async def open_ws(port: int) -> tuple[WsClient, str]:
    """A client and the worker that accepted it (the handshake's header)."""
    ws = await connect(f"ws://127.0.0.1:{port}", max_size=None)
    return WsClient(ws), ws.response.headers[WORKER_HEADER]


async def on_worker(port: int, worker: str, opened: list[WsClient],
                    timeout: float = 30.0) -> WsClient:
    """A client on ``worker``: connect until the kernel hands one to it (a restarted worker
    takes a moment to listen again), bounded in tries and time."""
    deadline = time.monotonic() + timeout
    for _ in range(MAX_TRIES * 8):
        client, served_by = await open_ws(port)
        if served_by == worker:
            opened.append(client)
            return client
        await client.close()
        if time.monotonic() > deadline:
            break
        await asyncio.sleep(0.02)
    raise AssertionError(f"no connection landed on worker {worker} within {timeout}s")


@pytest.fixture
async def clients(workers):
    opened: list[WsClient] = []

    async def pair() -> tuple[WsClient, WsClient]:
        return (await on_worker(workers.port, "0", opened),
                await on_worker(workers.port, "1", opened))

    yield pair
    for c in opened:
        await c.close()


async def param(client: WsClient, service: str, **args) -> dict:
    """A rosapi parameter service's values (its own ``name`` field clashes with rosapi())."""
    reply = await client.call(f"/rosapi/{service}", args)
    assert reply["result"], reply
    return reply["values"]


def worker_pids(parent: int) -> list[int]:
    """The parent's child processes (the workers), from /proc."""
    children = Path(f"/proc/{parent}/task/{parent}/children").read_text().split()
    return [int(pid) for pid in children]


def test_each_worker_logs_with_its_index():
    proc = subprocess.Popen(
        [sys.executable, "-m", "hitrobot_server", "--workers", "2", "--port", "0",
         "--tcp-port", "0", "--robot", "none", "--log-level", "info"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and (line := proc.stdout.readline()):
            lines.append(line)
            if "(2 workers)" in line:  # the parent's address line: every worker is serving
                break
    finally:
        proc.terminate()
        proc.wait(20)
    text = "".join(lines)
    assert "(2 workers)" in lines[-1], text
    assert "[worker 0] hitrobot_server.server" in text
    assert "[worker 1] hitrobot_server.server" in text


async def test_sixteen_clients_land_on_both_workers_and_each_publish_reaches_all(workers):
    opened = [await open_ws(workers.port) for _ in range(16)]
    clients = [c for c, _ in opened]
    try:
        served = {served_by for _c, served_by in opened}
        assert served == {"0", "1"}
        for c in clients:
            await c.send({"op": "subscribe", "topic": "/wt/chatter", "type": "std_msgs/String"})
            await c.send({"op": "advertise", "topic": "/wt/chatter", "type": "std_msgs/String"})
        one_each = [next(c for c, w in opened if w == worker) for worker in sorted(served)]

        async def everyone_subscribed() -> bool:  # the link told each worker the other's
            counts = [len((await rosapi(c, "subscribers", topic="/wt/chatter"))["subscribers"])
                      for c in one_each]
            return counts == [16, 16]

        await until(everyone_subscribed, 20, "16 subscribers seen from both workers")
        for i, c in enumerate(clients):
            await c.send({"op": "publish", "topic": "/wt/chatter", "msg": {"data": f"from {i}"}})
        sent = {f"from {i}" for i in range(16)}
        for c in clients:
            got = {(await c.expect(op="publish", topic="/wt/chatter"))["msg"]["data"]
                   for _ in range(16)}
            assert got == sent
    finally:
        for c in clients:
            await c.close()


async def test_services_actions_params_and_rosapi_answer_the_same_from_both(workers, clients):
    a, b = await clients()
    # a client's service on one worker, called from the other, both ways
    await a.send({"op": "advertise_service", "service": "/wt/toggle", "type": "std_srvs/SetBool"})
    await until_listed(b, "services", "/wt/toggle", 15)
    await b.send({"op": "call_service", "id": "c1", "service": "/wt/toggle",
                  "args": {"data": True}})
    req = await a.expect(op="call_service", service="/wt/toggle")
    await a.send({"op": "service_response", "service": "/wt/toggle", "id": req["id"],
                  "values": {"success": True, "message": "on"}, "result": True})
    reply = await b.expect(op="service_response", id="c1")
    assert reply["result"] and reply["values"] == {"success": True, "message": "on"}

    # a client's action on worker 1, a goal from worker 0
    await b.send({"op": "advertise_action", "action": "/wt/fib",
                  "type": "actionlib/action/TwoInts"})
    await until_listed(a, "action_servers", "/wt/fib", 15)
    await a.send({"op": "send_action_goal", "id": "g1", "action": "/wt/fib",
                  "action_type": "actionlib/TwoInts", "args": {"a": 2, "b": 3}})
    goal = await b.expect(op="send_action_goal", action="/wt/fib")
    await b.send({"op": "action_result", "id": goal["id"], "action": "/wt/fib",
                  "values": {"sum": 5}, "status": 4, "result": True})
    res = await a.expect(op="action_result", id="g1")
    assert res["status"] == 4 and res["values"] == {"sum": 5}

    # one parameter store (worker 0's): set from either, read the same from both
    await param(b, "set_param", name="/wt/speed", value="1.5")
    for c in (a, b):
        assert (await param(c, "get_param", name="/wt/speed"))["value"] == "1.5"
    await param(a, "set_param", name="/wt/mode", value='"patrol"')
    assert (await param(b, "get_param", name="/wt/mode"))["value"] == '"patrol"'
    assert (await param(b, "has_param", name="/wt/mode"))["exists"]
    names = [(await param(c, "get_param_names"))["names"] for c in (a, b)]
    assert names[0] == names[1] and {"/wt/speed", "/wt/mode"} <= set(names[0])
    reply = await b.call("/rosapi/delete_param", {"name": "/wt/absent"})
    assert not reply["result"] and "'/wt/absent' is not set" in reply["values"]

    # the nodes run once, in worker 0; their services answer from worker 1 too
    for c in (a, b):
        reply = await c.call("/republish_tfs", {
            "source_frames": ["base_link"], "target_frame": "map", "angular_thres": 0.1,
            "trans_thres": 0.1, "rate": 1.0, "timeout": {"secs": 1, "nsecs": 0}})
        assert reply["result"], reply
        assert reply["values"]["topic_name"].startswith("/tf_repub_")

    # rosapi's lists: the same from both (after the link has told each the other's state)
    async def same(listing: str) -> bool:
        got = [(await rosapi(c, listing))[listing] for c in (a, b)]
        return got[0] == got[1]

    for listing in ("topics", "services", "action_servers", "nodes"):
        await until(lambda listing=listing: same(listing), 15, f"the same {listing}")
    services = (await rosapi(a, "services"))["services"]
    assert services.count("/rosapi/get_param") == 1 and "/wt/toggle" in services


async def test_diagnostics_list_the_clients_of_every_worker(workers, clients):
    a, b = await clients()
    for c, topic in ((a, "/wt/diag_a"), (b, "/wt/diag_b")):  # their node names, via rosapi
        await c.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    names: set[str] = set()

    async def both_known() -> bool:
        names.clear()
        for topic in ("/wt/diag_a", "/wt/diag_b"):
            names.update((await rosapi(b, "publishers", topic=topic))["publishers"])
        return len(names) == 2

    await until(both_known, 15, "both clients' node names")
    await b.send({"op": "subscribe", "topic": "/diagnostics_agg"})  # published by worker 0

    async def listed_both() -> bool:
        msg = await b.expect(op="publish", topic="/diagnostics_agg", timeout=5)
        item = next(s for s in msg["msg"]["status"] if s["name"] == "/Bridge/Clients")
        values = {v["key"]: v["value"] for v in item["values"]}
        return names <= set(values["client names"].split())

    await until(listed_both, 20, "worker 0's diagnostics listing the clients of both workers")


async def test_bad_input_gets_the_same_status_on_every_worker(workers, clients):
    a, b = await clients()
    bad = ["{not json", '{"op": "warp"}', '{"op": "publish", "id": "p1", "msg": {}}',
           '{"op": "subscribe", "id": "s1", "topic": "/x", "throttle_rate": -1}',
           '{"op": "call_service", "id": "c1", "service": "/wt/nobody"}']
    answers = []
    for c in (a, b):
        got = []
        for text in bad:
            await c.send(text)
            got.append(await c.expect(lambda m: m.get("op") in ("status", "service_response")))
        answers.append(got)
    assert answers[0] == answers[1]
    assert all(m.get("level", "error") == "error" for m in answers[0][:4])
    assert [m.get("id") for m in answers[0][2:]] == ["p1", "s1", "c1"]
    for c in (a, b):  # and the connections keep working
        await round_trip(c)


async def test_the_console_loads_from_either_worker(workers):
    pages: dict[str, bytes] = {}
    async with aiohttp.ClientSession() as http:
        for _ in range(MAX_TRIES):
            # a new connection each time, so the kernel may pick the other worker
            async with http.get(f"http://127.0.0.1:{workers.port}/",
                                headers={"Connection": "close"}) as r:
                assert r.status == 200
                pages[r.headers[WORKER_HEADER]] = await r.read()
            if len(pages) == 2:
                break
    assert set(pages) == {"0", "1"} and pages["0"] == pages["1"]
    assert b"<html" in pages["0"].lower()


async def test_tcp_port_is_shared_too(workers):
    replies = []
    for _ in range(4):
        c = await TcpClient.open(workers.tcp_port)
        try:
            await c.send({"op": "call_service", "id": "t", "service": "/rosapi/get_param",
                          "args": {"name": "/wt/tcp", "default": "7"}})
            replies.append(await c.expect(op="service_response", id="t"))
        finally:
            await c.close()
    assert all(r["result"] and r["values"]["value"] == "7" for r in replies)


async def test_a_killed_worker_is_restarted_and_new_connections_work():
    server = ServerProcess("--workers", "2", "--log-level", "error")
    opened: list[WsClient] = []
    try:
        for victim in ("1", "0"):  # the bridge worker, then the robot's
            old = worker_pids(server.proc.pid)
            assert len(old) == 2
            dead = next(p for p in old if _worker_index(p) == victim)
            os.kill(dead, signal.SIGKILL)
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:  # bounded: wait for the parent to restart it
                now = worker_pids(server.proc.pid)
                if len(now) == 2 and dead not in now:
                    break
                await asyncio.sleep(0.1)
            else:
                raise AssertionError(f"worker {victim} was not restarted")
            a, b = (await on_worker(server.port, "0", opened),
                    await on_worker(server.port, "1", opened))

            async def params_cross(victim=victim, a=a, b=b) -> bool:
                """Worker 1 reaches worker 0's parameters again (the link is back)."""
                value = f'"after {victim}"'
                reply = await b.call("/rosapi/set_param", {"name": "/wt/back", "value": value})
                if not reply["result"]:
                    return False
                return (await param(a, "get_param", name="/wt/back"))["value"] == value

            await until(params_cross, 30, f"parameters across workers after {victim} restarted")
        last = worker_pids(server.proc.pid)
    finally:
        for c in opened:
            await c.close()
        server.stop()
    assert server.proc.returncode == 0  # the parent stopped cleanly, and its workers with it
    assert all(_gone(p) for p in last)


async def test_workers_stop_when_the_parent_is_killed():
    server = ServerProcess("--workers", "2", "--log-level", "error")
    pids = worker_pids(server.proc.pid)
    server.proc.kill()  # no chance to stop them: they see their stdin close
    server.proc.wait(10)
    await until_true(lambda: all(_gone(p) for p in pids), "the workers ending with their parent",
                     20)


def _worker_index(pid: int) -> str | None:
    """The ``--worker-id`` on a worker's command line (None just after the fork, before the
    worker's own command line is in place, or once it is gone)."""
    try:
        args = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return None
    if b"--worker-id" not in args:
        return None
    return args[args.index(b"--worker-id") + 1].decode()


def _gone(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z"
    except FileNotFoundError:
        return True


async def test_a_worker_that_keeps_dying_stops_the_server():
    """Killed five times, each within moments of its start, worker 1 is given up: the parent
    stops worker 0 too and exits 1 saying why (restarts are bounded, not endless)."""
    server = ServerProcess("--workers", "2", "--log-level", "warning")
    killed: set[int] = set()
    try:
        for _ in range(5):
            deadline = time.monotonic() + 30
            while True:  # bounded: the next incarnation of worker 1
                if server.proc.poll() is not None:
                    break
                fresh = [p for p in worker_pids(server.proc.pid)
                         if p not in killed and _worker_index(p) == "1"]
                if fresh:
                    os.kill(fresh[0], signal.SIGKILL)
                    killed.add(fresh[0])
                    break
                assert time.monotonic() < deadline, "worker 1 was not restarted"
                await asyncio.sleep(0.05)
        code = await asyncio.to_thread(server.proc.wait, 60)
        rest = server.proc.stdout.read()
    finally:
        server.stop()
    assert code == 1
    assert "worker 1 keeps exiting" in rest


def test_a_worker_that_cannot_start_is_a_clear_error(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "hitrobot_server", "--workers", "2", "--port", "0",
         "--tcp-port", "0", "--robot", "sim", "--world", str(tmp_path / "absent.yaml")],
        capture_output=True, text=True, timeout=90)
    assert out.returncode == 1 and "worker 0 did not start" in out.stderr


async def test_workers_serve_wss_on_one_port(cert):  # noqa: F811  (the fixture)
    """--ssl: every worker loads the certificate; wss:// connections land on both."""
    certfile, keyfile = cert
    proc = subprocess.Popen(
        [sys.executable, "-m", "hitrobot_server", "--workers", "2", "--port", "0",
         "--tcp-port", "0", "--robot", "none", "--log-level", "warning", "--ssl",
         "--certfile", certfile, "--keyfile", keyfile],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        port = None
        deadline = time.monotonic() + 60
        while port is None and time.monotonic() < deadline and (line := proc.stdout.readline()):
            if m := re.search(r"wss://[\d.]+:(\d+).*\(2 workers\)", line):
                port = int(m.group(1))
        assert port is not None, "the parent did not print its wss:// address"
        context = ssl.create_default_context(cafile=certfile)
        served = set()
        for _ in range(16):
            ws = await connect(f"wss://127.0.0.1:{port}", ssl=context)
            try:
                served.add(ws.response.headers[WORKER_HEADER])
                assert (await WsClient(ws).call("/rosapi/get_time"))["result"] is True
            finally:
                await ws.close()
        assert served == {"0", "1"}
    finally:
        proc.terminate()
        proc.wait(20)

"""``--workers``: the flag, ``--workers 1`` staying exactly one process without Zenoh, and a
clear error when Zenoh is missing."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from websockets.asyncio.client import connect

from hitrobot_server.cli import build_parser
from hitrobot_server.config import load
from hitrobot_server.robots import start_plan
from hitrobot_server.workers import reserve_port, without_workers_flag
from tests.helpers import ServerProcess, WsClient, round_trip
from tests.test_process_tree import BIG, alive, descendants, until_some, wait_for_line


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_workers_flag_and_toml(tmp_path):
    assert load(build_parser().parse_args([])).process.worker_count == 1
    assert load(build_parser().parse_args(["--workers", "3"])).process.worker_count == 3
    cfg = tmp_path / "c.toml"
    cfg.write_text("workers = 2\n")
    assert load(build_parser().parse_args(["--config", str(cfg)])).process.worker_count == 2
    auto = load(build_parser().parse_args(["--workers", "auto"]))
    assert auto.process.worker_count >= 1 and start_plan(auto).primary


@pytest.mark.parametrize("value", ["0", "-2", "two", "1.5"])
def test_bad_workers_value_is_refused(value):
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "--workers", value],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "workers must be a whole number" in out.stderr


def test_the_parent_passes_every_flag_but_its_own():
    argv = ["--port", "9", "--workers", "2", "--robot", "sim", "--workers=3", "--log-level",
            "debug"]
    assert without_workers_flag(argv) == ["--port", "9", "--robot", "sim", "--log-level",
                                          "debug"]


def test_a_reserved_port_is_shared_with_reuse_port_listeners_only():
    held = reserve_port("127.0.0.1", 0)
    port = held.getsockname()[1]
    try:
        with socket.socket() as plain, pytest.raises(OSError):  # nobody else takes it
            plain.bind(("127.0.0.1", port))
        worker = socket.socket()
        worker.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
        worker.bind(("127.0.0.1", port))
        worker.listen()
        with socket.create_connection(("127.0.0.1", port), timeout=5):
            conn, _ = worker.accept()  # the listening worker gets the connection
            conn.close()
        worker.close()
    finally:
        held.close()


def test_one_worker_runs_as_today_and_never_imports_zenoh():
    """``--workers 1`` through the command line: one process, serving, no Zenoh loaded."""
    port = free_port()
    code = (
        "import os, signal, socket, sys, threading, time\n"
        "from hitrobot_server.cli import main\n"
        "def stop_when_serving():\n"
        "    deadline = time.monotonic() + 60\n"
        "    while time.monotonic() < deadline:\n"
        "        try:\n"
        f"            socket.create_connection(('127.0.0.1', {port}), timeout=1).close()\n"
        "            break\n"
        "        except OSError:\n"
        "            time.sleep(0.05)\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "threading.Thread(target=stop_when_serving, daemon=True).start()\n"
        f"code = main(['--workers', '1', '--robot', 'none', '--port', '{port}',\n"
        "             '--tcp-port', '0', '--log-level', 'warning'])\n"
        "print('exit', code, 'zenoh' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=90, check=True)
    lines = out.stdout.strip().splitlines()
    assert f"ws://127.0.0.1:{port}" in lines[0] and "workers" not in lines[0]
    assert lines[-1] == "exit 0 False"


def test_more_workers_without_zenoh_is_a_clear_error():
    code = (
        "import sys\n"
        "sys.modules['zenoh'] = None  # as if eclipse-zenoh were not installed\n"
        "from hitrobot_server.cli import main\n"
        "sys.exit(main(['--workers', '2', '--robot', 'none', '--port', '0']))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 1
    assert "--workers above 1" in out.stderr and "hitrobot-server[zenoh]" in out.stderr


def test_a_port_in_use_is_a_clear_error():
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        out = subprocess.run([sys.executable, "-m", "hitrobot_server", "--workers", "2",
                              "--robot", "none", "--port", str(port), "--tcp-port", "0"],
                             capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and "in use" in out.stderr


async def test_a_killed_worker_0_with_a_pool_comes_back_in_seconds():
    """kill -9 of worker 0 once its offload pool exists: a new worker 0 serves in seconds
    (the parent waits for the process, not for its stdout, which the pool held open), and
    the old worker's pool and resource tracker exit with it."""
    server = ServerProcess("--workers", "2")
    try:
        wait_for_line(server, "(2 workers)")
        for _ in range(50):  # the kernel spreads connections: find one on worker 0
            ws = await connect(f"ws://127.0.0.1:{server.port}", max_size=None)
            if ws.response.headers.get("X-Hitrobot-Worker") == "0":
                break
            await ws.close()
        else:
            raise AssertionError("no connection reached worker 0")
        client = WsClient(ws)
        await client.send({"op": "advertise", "topic": "/big", "type": "std_msgs/String"})
        await client.send({"op": "publish", "topic": "/big", "msg": {"data": BIG}})
        await round_trip(client, timeout=30)
        await client.close()
        worker0 = next(p for p in descendants(server.proc.pid)
                       if b"--worker-id\x000\x00" in Path(f"/proc/{p}/cmdline").read_bytes())
        left = descendants(worker0)
        assert len(left) >= 2  # its pool's process and the resource tracker
        os.kill(worker0, signal.SIGKILL)
        killed = time.monotonic()
        wait_for_line(server, "worker 0 (pid", timeout=30)
        assert time.monotonic() - killed < 20  # a worker's own start (~5-9 s on a busy 2-core CI)
        assert await until_some(lambda: not any(alive(p) for p in left), 20)
    finally:
        server.stop()

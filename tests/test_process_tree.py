"""kill -9 of the server leaves nothing behind (issue 36, item 1): the worker pool's processes
and multiprocessing's resource tracker die with it, in every mode; a recorder writer finishes
its file, then exits too."""

from __future__ import annotations

import asyncio
import os
import time
from pathlib import Path

import pytest

from hitrobot_server.procmem import children
from tests.helpers import ServerProcess, WsClient, round_trip

BIG = "x" * (400 * 1024)  # above protocol.bulk.OFFLOAD_BYTES: parsed in the worker pool


def descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (children, their children...), bounded in depth."""
    found: set[int] = set()
    layer = [pid]
    for _ in range(6):
        layer = [child for p in layer for child in children(p)]
        found.update(layer)
        if not layer:
            break
    return found


def alive(pid: int) -> bool:
    """Running (not gone, not a zombie waiting to be reaped)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rpartition(")")[2].split()[0] != "Z"


async def big_publish(port: int, count: int = 1) -> None:
    """``count`` connections each publish one message big enough to go to the pool."""
    for i in range(count):
        client = await WsClient.open(port)
        await client.send({"op": "advertise", "topic": f"/big{i}", "type": "std_msgs/String"})
        await client.send({"op": "publish", "topic": f"/big{i}", "msg": {"data": BIG}})
        await round_trip(client, timeout=30)
        await client.close()


def wait_for_line(server: ServerProcess, text: str, timeout: float = 60) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = server.proc.stdout.readline()
        assert line, "".join(server.output)
        server.output.append(line)
        if text in line:
            return
    raise AssertionError(f"no {text!r} in time")


async def until_some(predicate, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        await asyncio.sleep(0.05)
    return predicate()


@pytest.mark.parametrize("mode", ["default", "record", "workers"])
async def test_kill_9_leaves_no_process_behind(mode, tmp_path):
    args: tuple[str, ...] = ()
    if mode == "record":
        args = ("--record", str(tmp_path / "run.mcap"))
    elif mode == "workers":
        args = ("--workers", "2")
    server = ServerProcess(*args)
    try:
        if mode == "workers":  # every worker serving (the first address printed is worker 0's)
            wait_for_line(server, "(2 workers)")
        before = descendants(server.proc.pid)
        await big_publish(server.port, count=4 if mode == "workers" else 1)
        # the pool's process has started (and, beside it, multiprocessing's resource tracker)
        assert await until_some(lambda: len(descendants(server.proc.pid)) > len(before), 30)
        tree = descendants(server.proc.pid)
        assert tree, "the server has child processes to leave behind"
        server.kill()
        assert await until_some(lambda: not any(alive(p) for p in tree), 20), (
            [(p, Path(f"/proc/{p}/cmdline").read_bytes()[:120]) for p in tree if alive(p)])
    finally:
        server.stop()
    if mode == "record":  # its writer finished the file before it exited
        assert (tmp_path / "run.mcap").read_bytes().endswith(b"\x89MCAP0\r\n")


def test_a_pool_process_whose_parent_is_already_gone_exits():
    """The race: the parent dies before the child asked for its death signal."""
    code = ("import os\nfrom hitrobot_server.session.offload import die_with_parent\n"
            "die_with_parent(os.getppid() + 1_000_000)\nprint('still here')\n")
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, env={**os.environ})
    assert out.returncode == 0 and "still here" not in out.stdout


def state_dir_of(pid: int) -> Path:
    """The ``--state-dir`` a process was started with (the replay's temporary folder)."""
    argv = Path(f"/proc/{pid}/cmdline").read_bytes().decode().split("\0")
    return Path(argv[argv.index("--state-dir") + 1])


@pytest.mark.parametrize("end", ["graceful", "kill -9"])
async def test_the_consoles_replay_and_its_folder_end_with_the_server(end, tmp_path):
    """"Open replay" starts a replay server; whichever way the live one ends, the replay (and
    its children) end too and its /tmp/hitrobot-replay-* folder goes."""
    from tests.record.test_player import make_recording

    folder = tmp_path / "recordings"
    folder.mkdir()
    await make_recording(folder / "r.mcap")
    server = ServerProcess("--record-dir", str(folder))
    try:
        client = await WsClient.open(server.port)
        try:
            reply = await client.call("/record/replay", {"name": "r"}, timeout=60)
            assert reply["result"] and reply["values"]["success"], reply
        finally:
            await client.close()
        tree = descendants(server.proc.pid)
        replay = [p for p in tree if b"replay" in Path(f"/proc/{p}/cmdline").read_bytes()]
        assert len(replay) == 1, tree
        state = state_dir_of(replay[0])
        assert state.name.startswith("hitrobot-replay-") and state.is_dir()
        if end == "kill -9":
            server.kill()
        else:
            server.stop()
        assert await until_some(lambda: not any(alive(p) for p in tree), 20), (
            [(p, Path(f"/proc/{p}/cmdline").read_bytes()[:120]) for p in tree if alive(p)])
        assert await until_some(lambda: not state.exists(), 10), list(state.iterdir())
    finally:
        server.stop()


async def test_a_killed_workers_parent_leaves_no_folder(tmp_path):
    """kill -9 of a --workers parent: its workers learn it from their stdin and remove its
    /tmp/hitrobot-workers-* folder (the parent cannot)."""
    server = ServerProcess("--workers", "2")
    try:
        wait_for_line(server, "(2 workers)")
        workers = [p for p in children(server.proc.pid)
                   if b"--worker-id" in Path(f"/proc/{p}/cmdline").read_bytes()]
        assert len(workers) == 2, workers
        environ = Path(f"/proc/{workers[0]}/environ").read_bytes().split(b"\0")
        shared = Path(next(v.split(b"=", 1)[1] for v in environ
                           if v.startswith(b"HITROBOT_METRICS_DIR=")).decode())
        assert shared.name.startswith("hitrobot-workers-") and shared.is_dir()
        server.kill()
        assert await until_some(lambda: not any(alive(p) for p in workers), 20)
        assert await until_some(lambda: not shared.exists(), 10), list(shared.iterdir())
    finally:
        server.stop()

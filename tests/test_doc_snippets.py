"""Every fenced code block of the README and of the manual (docs/*.md) runs, or is checked,
against a real server, as docs/index.md ("How the examples are tested") says:

- ``python``: run with this Python against a server with the simulated robot; exit 0.
- ``js``: an ES module beside tests/js's packages, run under Node; exit 0.
- ``bash``: run with ``bash -e``, ending by itself with status 0; or, when every command in it
  starts a server (``hitrobot-server``, ``… replay``, ``… sim-device``), the servers are started
  together, each must print its banner, and all are stopped (exit 0).
- ``toml``: loaded as a ``--config`` file by the server's own settings loader.
- ``json``: parsed (one value, or one per line).
- ``sh``: shown, not run: each command must be an install, the CI script, a benchmark, or a
  command for a real robot or another machine (checked below).
- ``ini``, ``text``: configuration and output, not run.

Ports: 9090/9091 become the shared server's, 9190/9191/7447/1448 fresh free loopback ports (one
mapping per page); a server command without ``--port`` gets ``--port 0`` (and ``--tcp-port -1``).
``hitrobot-server token …`` and ``… conformance`` are commands that end, not servers.
A page that names an MQTT broker (``mqtt://127.0.0.1:1883``: VDA 5050) gets a mosquitto of its
own and its own server with the simulated robot as a VDA 5050 vehicle on it (9090/9091/1883
become theirs); a server one of its fences starts gets a port where no broker listens, so it
does not take that vehicle's MQTT session over (it serves on without a broker).
Each page runs in its own temporary folder, which is also HOME and the XDG folders."""

from __future__ import annotations

import asyncio
import json
import os
import re
import shlex
import shutil
import socket
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from hitrobot_server.config import load
from tests.helpers import ServerProcess
from tests.vda5050.conftest import Broker

REPO = Path(__file__).resolve().parents[1]
JS = REPO / "tests" / "js"
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
TIMEOUT = 30  # seconds one snippet, or one server's start, may take

RUN = {"python", "js", "bash"}
CHECKED = {"toml", "json", "sh"}
SHOWN = {"ini", "text"}

# A `sh` command the tests cannot run here: an install, the CI script, a benchmark (minutes of
# load), systemd, or a robot or interface that is not this machine's loopback.
NOT_HERE = re.compile(
    r"\b(pip install|npm (ci|install)|apt-get|sudo|systemctl|journalctl|systemd-analyze)\b"
    r"|python3 -m venv|\.ci/run|\bbench/"
    r"|--robot\s+(\w+=)?https?://(?!127\.0\.0\.1)|--address\s+0\.0\.0\.0")
# The ports a snippet is written with (the defaults, and the examples' second server's).
SHARED_PORTS = ("9090", "9091")
FRESH_PORTS = ("9190", "9191", "7447", "1448")
BROKER = "mqtt://127.0.0.1:1883"  # a page naming it gets a broker and a vehicle (above)
VEHICLE = "uagv/v2/hitrobot/robot"  # the page server's topic tree: the defaults
SERVER_ONLY = re.compile(r"^hitrobot-server[^:\n]*: \S+://", re.M)


@dataclass
class Fence:
    page: Path
    line: int
    language: str
    code: str

    def __str__(self) -> str:
        return f"{self.page.relative_to(REPO)}:{self.line} ({self.language or 'no language'})"


def fences(page: Path) -> list[Fence]:
    """The page's fenced blocks (indented ones in lists too), their text dedented."""
    found, lines = [], page.read_text(encoding="utf-8").split("\n")
    i = 0
    while i < len(lines):
        opening = re.match(r"^(\s*)(`{3,})\s*([\w+-]*)", lines[i])
        if not opening:
            i += 1
            continue
        indent, ticks, language = opening.groups()
        body, j = [], i + 1
        while j < len(lines) and not lines[j].strip().startswith(ticks):
            body.append(lines[j][len(indent):] if lines[j].startswith(indent) else lines[j])
            j += 1
        found.append(Fence(page, i + 1, language, "\n".join(body) + "\n"))
        i = j + 1
    return found


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def on_ports(code: str, ports: dict[str, int]) -> str:
    for written, port in ports.items():
        code = re.sub(rf"(?<!\d){written}(?!\d)", str(port), code)
    return code


def commands(code: str) -> list[str]:
    """The fence's commands: comments and blank lines dropped, continuations joined."""
    joined = code.replace("\\\n", " ")
    return [line.strip() for line in joined.split("\n")
            if line.strip() and not line.strip().startswith("#")]


def starts_a_server(command: str) -> bool:
    argv = shlex.split(command, comments=True)
    return bool(argv) and argv[0] == "hitrobot-server" and not (
        {"--help", "-h", "--version"} & set(argv) or argv[1:2] in (["conformance"], ["token"]))


def environment(home: Path) -> dict[str, str]:
    """The snippets' environment: this Python's scripts first on PATH, every XDG folder in
    ``home`` (never the user's), output unbuffered."""
    env = {**os.environ, "HOME": str(home), "PYTHONUNBUFFERED": "1",
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    for name in ("XDG_STATE_HOME", "XDG_DATA_HOME", "XDG_CACHE_HOME", "XDG_CONFIG_HOME"):
        env[name] = str(home / name.lower())
    return env


async def run(argv: list[str], cwd: Path, env: dict[str, str]) -> tuple[int, str]:
    proc = await asyncio.create_subprocess_exec(
        *argv, cwd=cwd, env=env, stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.STDOUT)
    try:
        out, _ = await asyncio.wait_for(proc.communicate(), TIMEOUT)
    except TimeoutError:
        proc.kill()
        await proc.wait()
        return -1, f"did not end within {TIMEOUT} s"
    return proc.returncode, out.decode(errors="replace")


async def start_server(command: str, cwd: Path, env: dict[str, str], log: Path):
    """One server command of a fence, started on free ports; returns once it printed its
    banner (the line scripts and tests parse)."""
    argv = shlex.split(command, comments=True)
    if "--port" not in argv:
        argv += ["--port", "0"] if argv[1:2] == ["sim-device"] else [
            "--port", "0", "--tcp-port", "-1"]
    argv[0] = shutil.which("hitrobot-server", path=env["PATH"])
    proc = await asyncio.create_subprocess_exec(
        *argv, cwd=cwd, env=env, stdout=asyncio.subprocess.PIPE, stderr=log.open("ab"))
    seen = b""
    try:
        async with asyncio.timeout(TIMEOUT):
            while not SERVER_ONLY.search(seen.decode(errors="replace")):
                line = await proc.stdout.readline()
                if not line:
                    break
                seen += line
    except TimeoutError:
        pass
    if not SERVER_ONLY.search(seen.decode(errors="replace")):
        await stop(proc)
        raise AssertionError(f"{command!r} printed no banner:\n{seen.decode()}\n"
                             f"{log.read_text(errors='replace')[-3000:]}")
    return proc


async def stop(proc) -> int:
    if proc.returncode is None:
        proc.terminate()
        try:
            await asyncio.wait_for(proc.wait(), TIMEOUT)
        except TimeoutError:
            proc.kill()
            await proc.wait()
    return proc.returncode


async def run_servers(fence: Fence, code: str, cwd: Path, env: dict[str, str]) -> None:
    log = cwd / "servers.log"
    started = []
    try:
        for command in commands(code):
            started.append((command, await start_server(command, cwd, env, log)))
    finally:
        codes = [(command, await stop(proc)) for command, proc in reversed(started)]
    bad = [(command, rc) for command, rc in codes if rc != 0]
    assert not bad, f"{fence}: stopped with {bad}:\n{log.read_text(errors='replace')[-3000:]}"


async def run_fence(fence: Fence, ports: dict[str, int], cwd: Path, n: int) -> None:
    env = environment(cwd)
    code = on_ports(fence.code, ports)
    if fence.language == "python":
        (cwd / f"snippet{n}.py").write_text(code)
        rc, out = await run([sys.executable, f"snippet{n}.py"], cwd, env)
    elif fence.language == "js":
        if not (cwd / "node_modules").exists():
            (cwd / "node_modules").symlink_to(JS / "node_modules")
        (cwd / f"snippet{n}.mjs").write_text(code)
        rc, out = await run(["node", f"snippet{n}.mjs"], cwd, env)
    elif all(starts_a_server(command) for command in commands(code)):
        if "1883" in ports:  # not the page's broker: its vehicle would be taken over
            code = on_ports(fence.code, {**ports, "1883": free_port()})
        await run_servers(fence, code, cwd, env)
        return
    else:
        assert not any(starts_a_server(command) for command in commands(code)), (
            f"{fence}: a fence either starts servers or runs commands that end, not both")
        (cwd / f"snippet{n}.sh").write_text(code)
        rc, out = await run(["bash", "-e", f"snippet{n}.sh"], cwd, env)
    assert rc == 0, f"{fence} exited {rc}:\n{code}\n--- output ---\n{out[-4000:]}"


def check_fence(fence: Fence, cwd: Path, n: int) -> None:
    """The fences that are checked, not run."""
    if fence.language == "toml":
        path = cwd / f"config{n}.toml"
        path.write_text(fence.code)
        load(_Args(str(path)))  # parsed, every setting checked, as --config does
    elif fence.language == "json":
        try:
            json.loads(fence.code)
        except ValueError:
            for line in filter(str.strip, fence.code.split("\n")):
                json.loads(line)
    elif fence.language == "sh":
        runnable = [c for c in commands(fence.code) if not NOT_HERE.search(c)]
        assert not runnable, (f"{fence}: {runnable} can run here: make the fence `bash` so the "
                              "tests run it")


class _Args:
    """What ``config.load`` reads of the parsed flags: a config file and no flag."""

    def __init__(self, config: str):
        self.config = config

    def __getattr__(self, name: str):
        return None


def test_every_page_is_found():
    names = {page.name for page in PAGES}
    assert {"README.md", "index.md", "flags.md", "protocol.md", "security.md"} <= names
    assert not any("_incoming" in page.parts for page in PAGES)


def test_the_fence_rules_are_the_manuals():
    """docs/index.md's table names exactly the languages this test knows."""
    index = (REPO / "docs" / "index.md").read_text()
    table = index[index.index("## How the examples are tested"):]
    first_cells = re.findall(r"^\| (`[^|]*) \|", table, re.M)
    named = {name for cell in first_cells for name in re.findall(r"`(\w+)`", cell)}
    assert named == RUN | CHECKED | SHOWN


def test_the_fence_reader_finds_indented_fences(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("text\n\n- item\n\n  ```python\n  print(1)\n  ```\n\n```text\nx\n```\n")
    found = fences(page)
    assert [(f.language, f.code) for f in found] == [("python", "print(1)\n"), ("text", "x\n")]


def test_a_runnable_command_in_an_sh_fence_is_refused(tmp_path):
    fence = Fence(REPO / "README.md", 1, "sh", "hitrobot-server --help\npip install x\n")
    with pytest.raises(AssertionError, match="can run here"):
        check_fence(fence, tmp_path, 0)
    check_fence(Fence(REPO / "README.md", 1, "sh", "sudo systemctl enable x\n"), tmp_path, 0)


def test_token_commands_end_and_are_not_servers():
    assert not starts_a_server("hitrobot-server token add tablet-1 --role operator")
    assert not starts_a_server("hitrobot-server token list")
    assert starts_a_server("hitrobot-server --authenticate --port 9190")


@pytest.fixture(scope="module")
def docs_server(tmp_path_factory):
    """The server the python, js and bash snippets talk to: the simulated robot, its folders
    temporary."""
    home = tmp_path_factory.mktemp("docs-server")
    tcp = free_port()  # named: the banner's TCP port is not always the line ServerProcess reads
    proc = ServerProcess("--map-dir", str(home / "maps"), "--record-dir", str(home / "rec"),
                         "--tcp-port", str(tcp), robot="sim")
    proc.tcp_port = tcp
    yield proc
    proc.stop()


# A page may start several servers one after another (Zenoh pairs, --workers): each start is
# bounded by TIMEOUT, the page by this, above pytest's default for one test.
async def vehicle_online(port: int) -> None:
    """Once the page server's vehicle is on the broker: its retained ``connection`` ONLINE."""
    import aiomqtt  # the vda5050 extra, which the test extra installs

    async with asyncio.timeout(TIMEOUT), aiomqtt.Client("127.0.0.1", port) as client:
        await client.subscribe(f"{VEHICLE}/connection")
        async for message in client.messages:
            if json.loads(message.payload).get("connectionState") == "ONLINE":
                return


@pytest.fixture
async def page_server(request, docs_server, tmp_path):
    """The server (and the ports) a page's snippets talk to: the shared one, or for a page that
    names a broker, a mosquitto and a server of its own whose robot is a vehicle on it."""
    if BROKER not in request.node.callspec.params["page"].read_text(encoding="utf-8"):
        yield docs_server, {}
        return
    broker = Broker(tmp_path)
    tcp = free_port()
    try:
        server = ServerProcess("--vda5050", broker.url, "--tcp-port", str(tcp), robot="sim")
    except BaseException:
        broker.stop()
        raise
    server.tcp_port = tcp
    try:
        await vehicle_online(broker.port)
        yield server, {"1883": broker.port}
    finally:
        server.stop()
        broker.stop()


@pytest.mark.timeout(300)
@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
async def test_every_snippet_of_the_page_runs(page, page_server, tmp_path):
    found = fences(page)
    unknown = [str(f) for f in found if f.language not in RUN | CHECKED | SHOWN]
    assert not unknown, f"fences in a language the snippet test does not know: {unknown}"
    server, own_ports = page_server
    ports = {"9090": server.port, "9091": server.tcp_port,
             **{written: free_port() for written in FRESH_PORTS}, **own_ports}
    assert set(ports) - set(own_ports) == {*SHARED_PORTS, *FRESH_PORTS}
    for n, fence in enumerate(found):
        if fence.language in RUN:
            await run_fence(fence, ports, tmp_path, n)
        elif fence.language in CHECKED:
            check_fence(fence, tmp_path, n)


async def test_a_snippet_that_fails_fails_the_test(tmp_path):
    """The runner itself: a script's exit status and a server that never serves are failures."""
    with pytest.raises(AssertionError, match="exited 3"):
        await run_fence(Fence(REPO / "README.md", 1, "python", "raise SystemExit(3)\n"), {},
                        tmp_path, 0)
    with pytest.raises(AssertionError, match="printed no banner"):
        await run_fence(Fence(REPO / "README.md", 1, "bash",
                              "hitrobot-server --world no-such-world.yaml\n"), {}, tmp_path, 1)
    with pytest.raises(AssertionError, match="not both"):
        await run_fence(Fence(REPO / "README.md", 1, "bash",
                              "echo hi\nhitrobot-server --robot none\n"), {}, tmp_path, 2)

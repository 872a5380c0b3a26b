"""The README's "Connecting" snippets run verbatim against a real server: the roslibjs one under
Node with tests/js's roslib 2 (an ES module, imported), the roslibpy one under this Python, the
Foxglove one under Node with @foxglove/ws-protocol, the raw TCP one under bash. Only the ports
are changed (9090/9091 → the test server's ephemeral ones); each snippet must end by itself and
print what the README says it prints. (Every other fence of the README and docs/:
test_doc_snippets.py.)"""

from __future__ import annotations

import asyncio
import json
import re
import shutil
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
JS = REPO / "tests" / "js"
TIMEOUT = 30


def snippet(label: str, language: str) -> str:
    """The first ``language`` code block after the paragraph that starts with ``**label**``."""
    text = (REPO / "README.md").read_text()
    start = text.index(f"**{label}**")
    found = re.compile(rf"```{language}\n(.*?)```", re.S).search(text, start)
    assert found, f"no {language} block after {label!r} in the README"
    return found.group(1)


def on_ports(code: str, ws: int, tcp: int) -> str:
    return code.replace("9090", str(ws)).replace("9091", str(tcp))


async def run(*argv: str, cwd: Path) -> tuple[int, str, str]:
    proc = await asyncio.create_subprocess_exec(
        *argv, cwd=cwd, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    try:
        out, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
    except TimeoutError:
        proc.kill()
        await proc.wait()
        raise AssertionError(f"{argv[0]} did not end within {TIMEOUT} s") from None
    return proc.returncode, out.decode(), err.decode()


@pytest.fixture
async def ports(make_server):
    server = await make_server()  # tcp_port -1: TCP on an ephemeral port
    return server.port, server.tcp_port


async def test_the_roslibjs_snippet_runs_under_node_with_roslib_2(ports, tmp_path):
    if shutil.which("node") is None or not (JS / "node_modules" / "roslib").is_dir():
        raise RuntimeError("node and tests/js's packages are needed: `npm ci --prefix tests/js`"
                           " (.ci/run does this)")
    code = snippet("roslibjs", "js")
    assert code.startswith("import * as ROSLIB from 'roslib';")
    (tmp_path / "node_modules").symlink_to(JS / "node_modules")  # where `import` finds roslib
    (tmp_path / "hello.mjs").write_text(on_ports(code, *ports))
    rc, out, err = await run("node", "hello.mjs", cwd=tmp_path)
    assert rc == 0, err
    assert out.splitlines() == ["hello"], (out, err)


async def test_require_of_roslib_2_fails_as_the_readme_says(tmp_path):
    assert "`require('roslib')`\nfails on roslib 2" in (REPO / "docs" / "connecting.md").read_text()
    (tmp_path / "node_modules").symlink_to(JS / "node_modules")
    (tmp_path / "old.cjs").write_text("require('roslib');\n")
    rc, _out, err = await run("node", "old.cjs", cwd=tmp_path)
    assert rc != 0 and "roslib" in err


async def test_the_roslibpy_snippet_runs(ports, tmp_path):
    (tmp_path / "hello.py").write_text(on_ports(snippet("roslibpy", "python"), *ports))
    rc, out, err = await run(sys.executable, "hello.py", cwd=tmp_path)
    assert rc == 0, err
    lines = out.splitlines()
    assert len(lines) == 1, out
    assert re.search(r"\d{10}", lines[0]), out  # the server's clock: seconds since 1970


async def test_the_raw_tcp_snippet_runs_in_bash(ports, tmp_path):
    (tmp_path / "tcp.sh").write_text(on_ports(snippet("Raw TCP", "bash"), *ports))
    rc, out, err = await run("bash", "tcp.sh", cwd=tmp_path)
    assert rc == 0, err
    reply = json.loads(out.splitlines()[0])
    assert reply["op"] == "service_response" and reply["id"] == "1" and reply["result"] is True
    assert reply["values"]["time"]["secs"] > 0


async def test_the_foxglove_snippet_gets_a_message_under_node(make_server, tmp_path):
    server = await make_server(robot="sim")  # /odom: the simulated robot's
    ports = server.port, server.tcp_port
    code = snippet("Foxglove / Lichtblick", "js")
    (tmp_path / "node_modules").symlink_to(JS / "node_modules")
    (tmp_path / "odom.mjs").write_text(on_ports(code, *ports))
    rc, out, err = await run("node", "odom.mjs", cwd=tmp_path)
    assert rc == 0, err
    assert re.fullmatch(r"/odom: \d+ bytes of CDR\n", out), (out, err)


def test_the_test_step_never_reinstalls_the_quick_starts_environment():
    """Step 2 (.ci/run) under a running step 1: .ci/run makes and installs into its own venv,
    so the server of step 1 keeps its files (it used to reinstall .venv in editable mode under
    it, and the running console answered 404)."""
    quick = re.search(r"python3 -m venv (\S+) && \1/bin/pip install \.", (REPO / "README.md")
                      .read_text())
    assert quick, "the quick start's step 1 changed: update this test"
    ci = (REPO / ".ci" / "run").read_text()
    made = re.findall(r"python3 -m venv (\S+)", ci)
    assert made and quick.group(1) not in made
    assert f"{quick.group(1)}/bin" not in ci

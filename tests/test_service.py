"""A supervisor's contract (issue 36, item 7): sd_notify READY=1 once the port answers,
WATCHDOG=1 while the loop runs, STOPPING=1 on shutdown; the systemd unit in deploy/."""

from __future__ import annotations

import configparser
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hitrobot_server.signals import ServiceNotifier
from tests.helpers import ServerProcess, WsClient, round_trip

UNIT = Path(__file__).resolve().parents[1] / "deploy" / "hitrobot-server.service"


def datagrams(sock: socket.socket, want: str, timeout: float = 30) -> list[str]:
    """Every datagram until one holds the line ``want`` (bounded in time)."""
    got: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        sock.settimeout(max(0.01, deadline - time.monotonic()))
        try:
            text = sock.recv(4096).decode()
        except TimeoutError:
            break
        got.append(text)
        if want in text.splitlines():
            return got
    raise AssertionError(f"no {want} in {got}")


async def test_ready_watchdog_and_stopping_reach_notify_socket(tmp_path, monkeypatch):
    path = str(tmp_path / "notify.sock")
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(path)
        monkeypatch.setenv("NOTIFY_SOCKET", path)
        monkeypatch.setenv("WATCHDOG_USEC", "200000")  # 0.2 s: WATCHDOG=1 every 0.1 s
        monkeypatch.delenv("WATCHDOG_PID", raising=False)
        server = ServerProcess()
        try:
            ready = datagrams(sock, "READY=1")
            assert ready[0].splitlines()[0] == "READY=1"  # nothing said before it
            assert f":{server.port}" in ready[-1]  # STATUS= names the address
            client = await WsClient.open(server.port)  # it answers once READY=1 is out
            await round_trip(client)
            await client.close()
            datagrams(sock, "WATCHDOG=1", timeout=10)
            datagrams(sock, "WATCHDOG=1", timeout=10)
            server.proc.terminate()
            datagrams(sock, "STOPPING=1", timeout=30)
            assert server.proc.wait(30) == 0
        finally:
            server.stop()


def test_abstract_socket_and_no_socket():
    name = f"hitrobot-test-{os.getpid()}"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind("\0" + name)
        notifier = ServiceNotifier({"NOTIFY_SOCKET": "@" + name, "WATCHDOG_USEC": "5000000"})
        assert notifier.notify("READY=1", "STATUS=up") and notifier.watchdog == 5.0
        sock.settimeout(5)
        assert sock.recv(100) == b"READY=1\nSTATUS=up"
    silent = ServiceNotifier({})
    assert not silent.notify("READY=1") and silent.watchdog == 0.0
    other = ServiceNotifier({"NOTIFY_SOCKET": "@x", "WATCHDOG_USEC": "5", "WATCHDOG_PID": "1"})
    assert other.watchdog == 0.0  # the watchdog is another process's


def unit_sections() -> configparser.ConfigParser:
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.optionxform = str  # systemd keys are case-sensitive
    parser.read(UNIT)
    return parser


def test_the_unit_says_what_a_site_needs():
    unit = unit_sections()
    service = unit["Service"]
    assert service["Type"] == "notify" and int(service["WatchdogSec"]) > 0
    assert service["Restart"] == "on-failure" and service["DynamicUser"] == "yes"
    assert service["StateDirectory"] and service["RuntimeDirectory"]
    for key in ("NoNewPrivileges", "ProtectHome", "PrivateTmp", "PrivateDevices"):
        assert service[key] == "yes", key
    assert service["ProtectSystem"] == "strict"
    assert "${STATE_DIRECTORY}" in service["ExecStart"]  # the state lives where systemd says
    assert unit["Install"]["WantedBy"] == "multi-user.target"


def test_systemd_analyze_verifies_the_unit(tmp_path):
    """``systemd-analyze verify`` where it exists (the unit's ExecStart pointed at this
    checkout's installed command); elsewhere the unit is read as an INI file, key by key."""
    tool = shutil.which("systemd-analyze")
    if tool is None:
        unit = unit_sections()
        assert set(unit.sections()) == {"Unit", "Service", "Install"}
        assert unit["Service"]["ExecStart"].split()[0].endswith("/hitrobot-server")
        return
    command = Path(sys.executable).parent / "hitrobot-server"
    if not command.exists():
        pytest.fail(f"{command} is not installed (pip install -e .)")
    copy = tmp_path / UNIT.name
    copy.write_text(UNIT.read_text().replace("/opt/hitrobot-server/bin/hitrobot-server",
                                             str(command)))
    out = subprocess.run([tool, "verify", str(copy)], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert "Unknown" not in out.stderr and "hitrobot-server.service" not in out.stderr, out.stderr


def test_the_install_steps_build_the_console_and_say_how_to_authenticate():
    """Issue 46 (friction 8): the install steps run ``npm ci --prefix web`` before pip (else the
    console has no libraries), the unit names no documentation pip does not install, and its
    0.0.0.0 says how to add authentication."""
    unit = unit_sections()
    assert "Documentation" not in unit["Unit"] or \
        unit["Unit"]["Documentation"].startswith(("http://", "https://"))
    text = UNIT.read_text()
    before_exec = text[:text.index("ExecStart=")].rsplit("\n\n", 1)[-1]
    assert "--authenticate" in before_exec and "security page of the manual" in before_exec
    steps = (UNIT.parent.parent / "docs" / "operations.md").read_text()  # the manual's page
    block = steps[steps.index("### systemd"):]
    block = block[block.index("```sh"):block.index("```", block.index("```sh") + 5)]
    assert "npm ci --prefix web" in block
    assert block.index("npm ci --prefix web") < block.index("pip install")
    assert "--authenticate" in steps[steps.index("### systemd"):]

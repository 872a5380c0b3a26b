"""The command line: documented flags, TOML config, precedence."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from hitrobot_server.cli import build_parser
from hitrobot_server.config import load
from tests.helpers import ServerProcess

FLAGS = ["--port", "--address", "--tcp-port", "--authenticate", "--auth-secret-file",
         "--fragment-timeout", "--max-message-size", "--delay-between-messages",
         "--unregister-timeout", "--topics-glob", "--services-glob", "--params-glob",
         "--status-level", "--send-buffer-limit", "--log-level", "--config"]


def test_help_documents_every_flag():
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "--help"],
                         capture_output=True, text=True, check=True).stdout
    for flag in FLAGS:
        assert flag in out


def test_defaults_are_rosbridge_like_but_loopback():
    s = load(build_parser().parse_args([]))
    t = s.transport
    assert (t.port, t.address, t.tcp_port, s.session.status_level) == \
        (9090, "127.0.0.1", 9091, "error")
    assert s.session.fragment_timeout == 600 and s.bus.unregister_timeout == 10


def test_toml_config_then_flags_override(tmp_path):
    cfg = tmp_path / "server.toml"
    cfg.write_text('[server]\nport = 9999\ntopics-glob = "/robot/*"\nstatus_level = "warning"\n')
    s = load(build_parser().parse_args(["--config", str(cfg), "--port", "7000"]))
    assert s.transport.port == 7000  # flag beats file
    assert s.session.status_level == "warning"
    topics = s.session.topics_filter
    assert topics.allows("/robot/odom") and not topics.allows("/other")


def test_unknown_config_key_is_an_error(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[server]\nprot = 1\n")
    with pytest.raises(ValueError, match="prot"):
        load(build_parser().parse_args(["--config", str(cfg)]))


def test_bus_settings_from_toml_and_flags(tmp_path):
    cfg = tmp_path / "server.toml"
    cfg.write_text('bus = "zenoh"\nzenoh_connect = ["tcp/127.0.0.1:7447", "tcp/127.0.0.1:7448"]\n'
                   'zenoh-domain = 3\n')
    s = load(build_parser().parse_args(["--config", str(cfg),
                                        "--zenoh-listen", "tcp/127.0.0.1:7500"]))
    assert (s.bus.bus, s.bus.zenoh_domain, s.bus.zenoh_listen) == \
        ("zenoh", 3, "tcp/127.0.0.1:7500")
    from hitrobot_server.bus.zenoh.keys import endpoints

    assert endpoints(s.bus.zenoh_connect) == ["tcp/127.0.0.1:7447", "tcp/127.0.0.1:7448"]
    assert endpoints("tcp/127.0.0.1:1, tcp/127.0.0.1:2") == ["tcp/127.0.0.1:1", "tcp/127.0.0.1:2"]
    assert load(build_parser().parse_args([])).bus.bus == "local"


def test_unknown_bus_is_refused():
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "--bus", "mqtt"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "bus must be one of local, zenoh" in out.stderr


def test_bad_zenoh_endpoint_is_a_clear_error():
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "--robot", "none", "--port",
                          "0", "--tcp-port", "0", "--bus", "zenoh", "--zenoh-listen", "bogus"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and "zenoh endpoints" in out.stderr and "bogus" in out.stderr


@pytest.mark.parametrize(("flag", "loop"),
                         [((), "uvloop"), (("--event-loop", "asyncio"), "asyncio")])
def test_the_server_runs_on_uvloop_when_installed_unless_told_otherwise(flag, loop):
    server = ServerProcess("--log-level", "info", *flag)
    try:
        assert any(f"event loop: {loop}" in line for line in server.output), server.output
    finally:
        server.stop()


def test_unknown_event_loop_is_refused():
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "--event-loop", "trio"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "invalid choice" in out.stderr


def test_a_failed_start_on_zenoh_exits_instead_of_hanging(tmp_path):
    """The Zenoh session is closed again when the server cannot start (its threads kept the
    process alive after the error before)."""
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port",
                          "0", "--bus", "zenoh", "--world", str(tmp_path / "absent.yaml")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and "absent.yaml" in out.stderr


HELP_SNAPSHOT = Path(__file__).with_name("cli_help.txt")


def _help_text() -> str:
    env = {**os.environ, "COLUMNS": "100"}  # argparse wraps to the terminal's width
    return subprocess.run([sys.executable, "-m", "hitrobot_server", "--help"], env=env,
                          capture_output=True, text=True, check=True).stdout


def test_help_matches_its_snapshot():
    """`--help` as a user reads it; refresh with UPDATE_SNAPSHOT=1 after a deliberate change."""
    text = _help_text()
    if os.environ.get("UPDATE_SNAPSHOT") == "1":
        HELP_SNAPSHOT.write_text(text)
    assert text == HELP_SNAPSHOT.read_text()


def test_help_names_each_default_once_and_the_tools_in_usage():
    text = _help_text()
    assert "(default: None)" not in text
    flat = " ".join(text.split())
    assert flat.count("(default: the built-in office)") == 1
    assert "(default: $XDG_DATA_HOME/hitrobot-server/maps)" in flat
    assert not re.search(r"\(default:[^)]*\)\s*\(default:", flat)
    usage = text.split("\n\n", 1)[0].splitlines()
    assert usage[0].startswith("usage: hitrobot-server")
    assert any("hitrobot-server conformance --url" in line for line in usage)
    assert any("hitrobot-server sim-device" in line for line in usage)
    assert "--demo-services" in flat
    # booleans read on/off, numbers stay numbers (1.0 and 0.0 are not "on" and "off")
    assert "twice as fast) (default: 1.0)" in flat and "to a client (default: 0.0)" in flat
    assert "permessage-deflate (default: off)" in flat
    assert "--tcp-port, --tcp_port TCP_PORT" in flat  # the value once, after the spellings


def test_demo_services_are_off_unless_asked(tmp_path):
    assert not load(build_parser().parse_args([])).node_options().demo_services
    assert load(build_parser().parse_args(["--demo-services"])).node_options().demo_services
    cfg = tmp_path / "server.toml"
    cfg.write_text("demo_services = true\n")
    assert load(build_parser().parse_args(["--config", str(cfg)])).nodes.demo_services


def test_ssl_runs_on_asyncio_and_refuses_uvloop(tmp_path):
    """uvloop's start_tls lost handshakes taken over by the TLS gate: --ssl picks asyncio."""
    args = ["--ssl", "--certfile", str(tmp_path / "c.pem")]
    assert load(build_parser().parse_args(args)).event_loop == "asyncio"
    with pytest.raises(ValueError, match="uvloop"):
        load(build_parser().parse_args([*args, "--event-loop", "uvloop"]))


def test_uvloop_comes_with_the_default_install():
    """`pip install .` (the quick start) brings uvloop, so `auto` runs on it: a base requirement
    of the installed package, not an extra nobody names."""
    from importlib.metadata import requires

    base = [r for r in requires("hitrobot-server") or [] if "extra ==" not in r]
    assert any(r.startswith("uvloop") for r in base), base

"""``hitrobot-server sim-device``: the simulated robot served over REST from the command line."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import urllib.request

from hitrobot_server.robot.rest import paths


def test_help_documents_the_flags_and_what_is_not_emulated():
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "sim-device", "--help"],
                         capture_output=True, text=True, check=True).stdout
    for flag in ("--port", "--address", "--world", "--sim-speed", "--sim-seed", "--sim-mapping"):
        assert flag in out
    assert "1448" in out and "127.0.0.1" in out and "Not emulated" in out


def test_sim_device_serves_the_rest_api_until_terminated():
    proc = subprocess.Popen(
        [sys.executable, "-m", "hitrobot_server", "sim-device", "--port", "0", "--sim-speed",
         "2", "--sim-mapping", "--log-level", "warning"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        line = proc.stdout.readline()
        m = re.search(r"http://127\.0\.0\.1:(\d+)", line)
        assert m, line
        url = m.group(0)
        with urllib.request.urlopen(url + paths.CAPABILITIES, timeout=5) as resp:
            caps = json.loads(resp.read())
        assert {"name": "slamware.agent.core", "enabled": True}.items() <= caps[0].items()
        with urllib.request.urlopen(url + paths.MAPPING_ENABLE, timeout=5) as resp:
            assert resp.read() == b"true"  # --sim-mapping; a bare JSON boolean
        req = urllib.request.Request(url + paths.CURRENT_ACTION)
        try:
            urllib.request.urlopen(req, timeout=5)
            raise AssertionError("an idle robot has no current action")
        except urllib.error.HTTPError as exc:
            assert exc.code == 404
    finally:
        proc.terminate()
        proc.wait(10)
    assert proc.returncode == 0


def test_bad_speed_is_refused():
    done = subprocess.run([sys.executable, "-m", "hitrobot_server", "sim-device",
                           "--sim-speed", "0"], capture_output=True, text=True)
    assert done.returncode == 2 and "sim-speed" in done.stderr

"""Runs roslibpy's own test suite against a real ``hitrobot-server --demo-services``.

Their tests dial ``127.0.0.1:9090`` (written in each test, no setting), so this script is run
inside a network namespace of its own (``unshare -n``): its loopback is new, port 9090 always
free there, and nothing of the host is reached or taken. Usage::

    unshare -n python roslibpy_suite_runner.py SUITE_DIR TRANSPORT STATE_DIR

It brings the namespace's loopback up, starts the server on 9090, runs their pytest in
``SUITE_DIR`` with ``ROSLIBPY_TRANSPORT=TRANSPORT`` and exits with pytest's status.

One of their tests is left out, named in ``NOT_OF_THE_SERVER``: ``test_ws_headers.py`` starts a
websockets server of its own on port 9000 (with websockets' legacy two-argument handler) and
checks the headers roslibpy sends to it; it never reaches the server under test, and it stops
that server by setting an ``asyncio.Event`` from another thread, which under load leaves it
running ("Server did not stop as expected").
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time

PORT = 9090  # what every test of theirs dials
START_TIMEOUT = 30.0
SUITE_TIMEOUT = 150.0


def start_server(state_dir: str) -> subprocess.Popen:
    """The server on 9090, returned once its banner says it listens. Its output goes to a
    file beside its state folder (a pipe no one reads would fill and stop it)."""
    log_path = os.path.join(state_dir, "server.log")
    with open(log_path, "w") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "hitrobot_server", "--port", str(PORT), "--tcp-port", "-1",
             "--address", "127.0.0.1", "--robot", "none", "--demo-services",
             "--state-dir", os.path.join(state_dir, "state")],
            stdout=log, stderr=subprocess.STDOUT, env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
    deadline = time.monotonic() + START_TIMEOUT
    while time.monotonic() < deadline and proc.poll() is None:
        with open(log_path) as log:
            if re.search(rf"ws://127\.0\.0\.1:{PORT}\b", log.read()):
                return proc
        time.sleep(0.1)  # (a file has no readiness to wait on; bounded by START_TIMEOUT)
    proc.kill()
    with open(log_path) as log:
        raise SystemExit(f"the server did not start:\n{log.read()}")


NOT_OF_THE_SERVER = ("tests/test_ws_headers.py",)
"""Their tests that talk to a server of their own, not to ours (see above)."""


def main(suite: str, transport: str, state_dir: str) -> int:
    subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
    server = start_server(state_dir)
    try:
        return subprocess.call(
            [sys.executable, "-m", "pytest", "tests", "-q", "-p", "no:xdist",
             "-p", "no:cacheprovider", "--timeout", "60",
             *(f"--deselect={test}" for test in NOT_OF_THE_SERVER)],
            cwd=suite, env={**os.environ, "ROSLIBPY_TRANSPORT": transport},
            timeout=SUITE_TIMEOUT,
        )
    finally:
        with open(os.path.join(state_dir, "server.log")) as log:
            print("--- the server's last lines ---", *log.readlines()[-20:], sep="", end="")
        server.terminate()
        try:
            server.wait(10)
        except subprocess.TimeoutExpired:
            server.kill()


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:4]))

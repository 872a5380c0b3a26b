"""The Foxglove column of the access matrix (issue 47): the real @foxglove/ws-protocol client of
each role (its token in the URL) against subscribe, clientPublish (advertise, then messages on
/cmd_vel under and over the agent's cap), serviceCall, get/setParameters and playbackControl;
each refused or not as the role table says. One server and one run of the script for all."""

from __future__ import annotations

import json
import subprocess
import threading

import pytest

from hitrobot_server.state.tokens import add_token, tokens_path
from tests.clients.test_roslibjs import JS
from tests.helpers import ServerProcess
from tests.session.test_access_matrix import CHANGERS, READERS, ROLES

CELLS: dict[str, set[str]] = {
    "subscribe": READERS,
    "advertise": CHANGERS,
    "publish_drive": CHANGERS | {"agent"},
    "publish_drive_over_the_agents_cap": CHANGERS,
    "call_read_only": READERS,
    "call_param_set": {"admin"},
    "get_parameters": READERS,
    "set_parameters": {"admin"},
    "playback_control": CHANGERS,
}


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> dict[str, str]:
    """role/cell → "refused: reason" or "done", from one run of foxglove_access.mjs."""
    state = tmp_path_factory.mktemp("state")
    tokens = {role: add_token(tokens_path(state), f"{role}-fox", role, None) for role in ROLES}
    proc = ServerProcess("--authenticate", "--state-dir", str(state), robot="sim")
    drain = threading.Thread(target=lambda: proc.output.extend(proc.proc.stdout), daemon=True)
    drain.start()  # the server's log read as it comes (a full pipe would stop it)
    try:
        run = subprocess.run(["node", str(JS / "foxglove_access.mjs"),
                              f"ws://127.0.0.1:{proc.port}", json.dumps(tokens)],
                             capture_output=True, text=True, timeout=120, cwd=JS)
    finally:
        proc.stop()
        drain.join(10)
    assert "ok finished" in run.stdout, run.stdout + run.stderr
    found = {}
    for line in run.stdout.splitlines():
        verdict, _, rest = line.partition(" ")
        if verdict in ("refused", "done"):
            key, _, reason = rest.partition(": ")
            found[key] = f"{verdict}: {reason}" if reason else verdict
    return found


@pytest.mark.parametrize(("role", "cell"), [(r, c) for r in ROLES for c in CELLS])
def test_foxglove(outcomes, role, cell):
    got = outcomes[f"{role}/{cell}"]
    if role in CELLS[cell]:
        assert got == "done", (role, cell, got)
    else:
        assert got.startswith("refused") and f"role '{role}'" in got, (role, cell, got)

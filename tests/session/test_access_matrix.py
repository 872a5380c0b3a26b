"""Every role against every op kind (issue 47's test matrix), over rosbridge on WebSocket (the
real roslibpy client, its token as an ``Authorization: Bearer`` header), raw TCP (the token in
the first line, an ``auth`` op) and HTTP (plain urllib). One server process for the module (a
simulated robot, ``--authenticate``), one token per role; each cell allowed or refused as the
role table says, a refusal naming the role."""

from __future__ import annotations

import json
import re
import socket
import threading
import time
import urllib.error
import urllib.request

import pytest
import roslibpy

from hitrobot_server.state.tokens import add_token, tokens_path
from tests.helpers import ServerProcess

ROLES = ("viewer", "operator", "admin", "agent", "monitor")
READERS = {"viewer", "operator", "admin", "agent"}
CHANGERS = {"operator", "admin"}

POSE = {"header": {"frame_id": "map"},
        "pose": {"position": {"x": 0.5, "y": 0.0, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
SLOW = {"linear": {"x": 0.1, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
FAST = {"linear": {"x": 1.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}

# cell: (the roles allowed, the rosbridge op)
CELLS: dict[str, tuple[set[str], dict]] = {
    "subscribe": (READERS, {"op": "subscribe", "topic": "/scan"}),
    "advertise": (CHANGERS, {"op": "advertise", "topic": "/matrix/chatter",
                             "type": "std_msgs/String"}),
    "publish_drive": (CHANGERS | {"agent"}, {"op": "publish", "topic": "/cmd_vel",
                                             "msg": SLOW}),
    "publish_drive_over_the_agents_cap": (CHANGERS, {"op": "publish", "topic": "/cmd_vel",
                                                     "msg": FAST}),
    "publish_goal_to_a_poi": (CHANGERS | {"agent"}, {
        "op": "publish", "topic": "/navigation/navigate_to_poi", "msg": {"name": "nowhere"}}),
    "publish_poi": (CHANGERS, {"op": "publish", "topic": "/map_manager/delete_poi",
                               "msg": {"name": "nowhere"}}),
    "publish_cmd_string": ({"admin"}, {"op": "publish", "topic": "/cmd_string",
                                       "msg": {"data": "matrix"}}),
    "call_read_only": (READERS, {"op": "call_service", "service": "/rosapi/get_time"}),
    "call_param_get": (READERS, {"op": "call_service", "service": "/rosapi/get_param",
                                 "args": {"name": "/rosdistro", "default": ""}}),
    "call_param_set": ({"admin"}, {"op": "call_service", "service": "/rosapi/set_param",
                                   "args": {"name": "/matrix", "value": "1"}}),
    "call_recordings_list": (READERS, {"op": "call_service", "service": "/record/list"}),
    "call_replay": (CHANGERS, {"op": "call_service", "service": "/record/replay",
                               "args": {"name": "absent.mcap"}}),
    "call_map_load": ({"admin"}, {"op": "call_service", "service": "/load_laser_map",
                                  "args": {"name": "absent"}}),
    "call_whoami": (set(ROLES), {"op": "call_service", "service": "/hitrobot/whoami"}),
    "advertise_service": (CHANGERS, {"op": "advertise_service", "service": "/matrix/svc",
                                     "type": "std_srvs/Trigger"}),
    "advertise_action": (CHANGERS, {"op": "advertise_action", "action": "/matrix/act",
                                    "type": "move_base_msgs/MoveBase"}),
    "send_action_goal": (CHANGERS, {"op": "send_action_goal", "action": "/move_base",
                                    "action_type": "move_base_msgs/MoveBase",
                                    "args": {"target_pose": POSE}}),
    "cancel_action_goal": (CHANGERS | {"agent"}, {"op": "cancel_action_goal",
                                                  "action": "/move_base", "id": "none"}),
}
MATRIX = [(role, cell) for role in ROLES for cell in CELLS]


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The server and a token per role (and its recordings folder, its output)."""
    state = tmp_path_factory.mktemp("state")
    tokens = {role: add_token(tokens_path(state), f"{role}-1", role, None) for role in ROLES}
    records = tmp_path_factory.mktemp("recordings")
    (records / "ok.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\0" * 64)
    proc = ServerProcess("--authenticate", "--state-dir", str(state), "--record-dir",
                         str(records), robot="sim")
    drain = threading.Thread(target=_drain, args=(proc,), daemon=True)
    drain.start()  # its log is read as it comes (a full pipe would stop the server)
    deadline = time.monotonic() + 30
    while proc.tcp_port is None and time.monotonic() < deadline:
        time.sleep(0.01)
    yield proc, tokens
    proc.stop()
    drain.join(10)


def _drain(proc: ServerProcess) -> None:
    """Keep the server's output in ``proc.output``; learn its TCP port from its banner (the
    helper stops at the log line before it)."""
    for line in proc.proc.stdout:
        proc.output.append(line)
        match = re.search(r"tcp://[\d.]+:(\d+)", line)
        if match:
            proc.tcp_port = int(match.group(1))


# ---------------------------------------------------------------- rosbridge over WebSocket
class RoslibpyClient:
    """roslibpy connected with a role's token in its upgrade request's header; the statuses
    it is sent are kept (roslibpy has no handler of its own for them)."""

    def __init__(self, port: int, token: str):
        self.ros = roslibpy.Ros("127.0.0.1", port, headers={"Authorization": f"Bearer {token}"})
        self.ros.run(timeout=10)
        self.statuses: list[dict] = []
        self.lock = threading.Lock()
        proto = self.ros.factory._proto
        proto._message_handlers["status"] = self._status
        self.whoami = roslibpy.Service(self.ros, "/hitrobot/whoami", "std_srvs/Trigger")

    def _status(self, message) -> None:
        with self.lock:
            self.statuses.append(dict(message))

    def refusals(self, op: dict) -> list[str]:
        """Send ``op``; once a later call is answered (ops are handled in order), the error
        statuses it got that name a role."""
        with self.lock:
            self.statuses.clear()
        self.ros.send_on_ready(roslibpy.Message(dict(op, id=f"cell:{time.monotonic_ns()}")))
        self.whoami.call(roslibpy.ServiceRequest({}), timeout=10)
        with self.lock:
            return [s["msg"] for s in self.statuses
                    if s.get("level") == "error" and is_refusal(s.get("msg", ""))]


@pytest.fixture(scope="module")
def ws_clients(site):
    proc, tokens = site
    clients = {role: RoslibpyClient(proc.port, tokens[role]) for role in ROLES}
    yield clients
    for client in clients.values():
        client.ros.close()


@pytest.mark.parametrize(("role", "cell"), MATRIX)
def test_rosbridge_websocket(ws_clients, role, cell):
    allowed, op = CELLS[cell]
    refusals = ws_clients[role].refusals(op)
    assert_cell(role, cell, allowed, refusals)


REFUSALS = ("lacks the permission", "may drive at most", "may send goals only")


def is_refusal(text: str) -> bool:
    """A role check's refusal (not a node's answer, nor the drive lease's)."""
    return any(words in text for words in REFUSALS)


def assert_cell(role: str, cell: str, allowed: set[str], refusals: list[str]) -> None:
    if role in allowed:
        assert not refusals, (role, cell, refusals)
    else:
        assert refusals and all(f"role '{role}'" in r for r in refusals), (role, cell)


def test_whoami_tells_the_name_role_and_permissions(ws_clients):
    answer = ws_clients["agent"].whoami.call(roslibpy.ServiceRequest({}), timeout=10)
    who = json.loads(answer["message"])
    assert who["name"] == "agent-1" and who["role"] == "agent" and who["authenticate"]
    assert "drive" in who["permissions"] and "shell" not in who["permissions"]


# ---------------------------------------------------------------- rosbridge over raw TCP
class TcpClient:
    """A raw TCP connection whose first line is ``{"op": "auth", "token": ...}``."""

    def __init__(self, port: int, token: str):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=10)
        self.file = self.sock.makefile("r", encoding="utf-8")
        self.send({"op": "auth", "token": token, "id": "login"})
        self.n = 0

    def send(self, op: dict) -> None:
        self.sock.sendall(json.dumps(op).encode() + b"\n")

    def refusals(self, op: dict) -> list[str]:
        self.n += 1
        sync = f"sync:{self.n}"
        self.send(dict(op, id=f"cell:{self.n}"))
        self.send({"op": "call_service", "service": "/hitrobot/whoami", "id": sync})
        found = []
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            message = json.loads(self.file.readline())
            if message.get("op") == "service_response" and message.get("id") == sync:
                return found
            if message.get("op") == "status" and message.get("id") == f"cell:{self.n}" \
                    and is_refusal(message.get("msg", "")):
                found.append(message["msg"])
        raise AssertionError("no answer to the round trip")

    def close(self) -> None:
        self.sock.close()


@pytest.fixture(scope="module")
def tcp_clients(site):
    proc, tokens = site
    clients = {role: TcpClient(proc.tcp_port, tokens[role]) for role in ROLES}
    yield clients
    for client in clients.values():
        client.close()


@pytest.mark.parametrize(("role", "cell"), MATRIX)
def test_rosbridge_tcp(tcp_clients, role, cell):
    allowed, op = CELLS[cell]
    assert_cell(role, cell, allowed, tcp_clients[role].refusals(op))


# ---------------------------------------------------------------- HTTP
HTTP_CELLS = {
    "/metrics": READERS - {"agent"} | {"monitor"},
    "/healthz": READERS - {"agent"} | {"monitor"},
    "/recordings/ok.mcap": READERS - {"agent"},
}


def get(port: int, path: str, headers: dict | None = None) -> tuple[int, bytes]:
    request = urllib.request.Request(f"http://127.0.0.1:{port}{path}", headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, response.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


@pytest.mark.parametrize("how", ["bearer", "query"])
@pytest.mark.parametrize(("role", "path"), [(r, p) for r in ROLES for p in HTTP_CELLS])
def test_http(site, role, path, how):
    proc, tokens = site
    token = tokens[role]
    if how == "bearer":
        status, body = get(proc.port, path, {"Authorization": f"Bearer {token}"})
    else:
        status, body = get(proc.port, f"{path}?token={token}")
    if role in HTTP_CELLS[path]:
        assert status in (200, 503), (role, path, status, body)  # 503: /healthz, not ready
    else:
        assert status == 403 and f"role '{role}'".encode() in body, (role, path, status)


@pytest.mark.parametrize("path", [*HTTP_CELLS, "/recordings/ok.mcap?token=wrong"])
def test_http_without_a_good_token_is_401(site, path):
    proc, _tokens = site
    status, body = get(proc.port, path)
    assert status == 401 and b"token" in body and b"MCAP" not in body


def test_the_console_files_are_served_to_sign_in_on(site):
    proc, _tokens = site
    status, body = get(proc.port, "/")
    assert status == 200 and b"<html" in body.lower()

"""``/record/start``, ``/record/stop``, ``/record/list`` and ``/record/state`` from a client, and
the download of a recording over HTTP on the same port (only the recordings folder)."""

from __future__ import annotations

import os
import signal

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from tests.helpers import WsClient
from tests.transport.test_http import http


async def test_start_list_download_and_stop_a_recording(make_server, tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(record_dir=str(folder))
    client = await WsClient.open(server.port)
    try:
        await client.send({"op": "subscribe", "topic": "/record/state"})
        idle = await client.expect(op="publish", topic="/record/state")
        assert idle["msg"]["recording"] is False
        reply = await client.call("/record/start", {"name": "first"})
        assert reply["values"] == {"success": True, "file": "first.mcap",
                                   "message": "recording to first.mcap"}
        state = await client.expect(op="publish", topic="/record/state")
        assert state["msg"]["recording"] and state["msg"]["file"] == "first.mcap"
        again = await client.call("/record/start", {"name": "second"})
        assert not again["result"] and "already recording to first.mcap" in again["values"]
        status = await client.expect(op="status")
        assert status["level"] == "error" and "already recording" in status["msg"]

        await client.send({"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
        for i in range(5):
            await client.send({"op": "publish", "topic": "/chatter", "msg": {"data": f"hi {i}"}})
        stopped = await client.call("/record/stop", timeout=60)  # the writer may be starting
        assert stopped["values"]["success"], stopped
        refused = await client.call("/record/stop")
        assert not refused["result"] and refused["values"] == "not recording"
        listed = (await client.call("/record/list"))["values"]
        assert listed["files"] == ["first.mcap"]
        assert listed["sizes"] == [(folder / "first.mcap").stat().st_size]

        status, headers, body = await http(server.port, "GET", "/recordings/first.mcap")
        assert status == 200 and body == (folder / "first.mcap").read_bytes()
        assert headers["content-type"] == "application/octet-stream"
        assert "attachment" in headers["content-disposition"]
        texts = []
        with open(folder / "first.mcap", "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _s, _c, _m, msg in reader.iter_decoded_messages(topics=["/chatter"]):
                texts.append(msg.data)
        assert texts == [f"hi {i}" for i in range(5)]
    finally:
        await client.close()


async def test_bad_names_are_refused_and_nothing_is_written(make_server, tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(record_dir=str(folder))
    client = await WsClient.open(server.port)
    try:
        for name in ("../escape", "sub/dir", ".hidden", "x" * 80):
            reply = await client.call("/record/start", {"name": name})
            assert not reply["result"] and "field 'name'" in reply["values"], name
            status = await client.expect(op="status", id=reply["id"])
            assert status["level"] == "error" and "field 'name'" in status["msg"]
        assert not folder.exists() or not any(folder.iterdir())
        assert server.recording.recorder is None
    finally:
        await client.close()


def folder_with_one(tmp_path):
    """A recordings folder holding ok.mcap (just the magic)."""
    folder = tmp_path / "recordings"
    folder.mkdir()
    (folder / "ok.mcap").write_bytes(b"\x89MCAP0\r\n")
    return folder


async def test_download_refuses_traversal_and_other_files(make_server, tmp_path):
    folder = folder_with_one(tmp_path)
    (tmp_path / "secret.mcap").write_bytes(b"secret")
    (folder / "notes.txt").write_text("no")
    (folder / "sub").mkdir()
    (folder / "sub" / "deep.mcap").write_bytes(b"deep")
    os.symlink(tmp_path / "secret.mcap", folder / "link.mcap")
    server = await make_server(record_dir=str(folder))
    status, _h, body = await http(server.port, "GET", "/recordings/ok.mcap")
    assert status == 200 and body == b"\x89MCAP0\r\n"
    for path in ("/recordings/../secret.mcap", "/recordings/%2e%2e/secret.mcap",
                 "/recordings/..%2fsecret.mcap", "/recordings/%2e%2e%2fsecret.mcap",
                 "/recordings/sub/deep.mcap", "/recordings/sub%2fdeep.mcap",
                 "/recordings/link.mcap", "/recordings/notes.txt", "/recordings/",
                 "/recordings/..%5csecret.mcap", "/recordings/missing.mcap"):
        status, _h, body = await http(server.port, "GET", path)
        assert status == 404 and b"secret" not in body, path
    status, _h, _b = await http(server.port, "POST", "/recordings/ok.mcap")
    assert status == 405


async def test_a_writer_that_dies_ends_the_recording_visibly(make_server, tmp_path, caplog):
    server = await make_server(record_dir=str(tmp_path))
    client = await WsClient.open(server.port)
    try:
        await client.send({"op": "subscribe", "topic": "/record/state"})
        assert (await client.call("/record/start", {"name": "doomed"}))["values"]["success"]
        await client.expect(lambda m: m.get("topic") == "/record/state"
                            and m["msg"]["recording"])
        os.kill(server.recording.recorder._process.pid, signal.SIGKILL)
        await client.expect(lambda m: m.get("topic") == "/record/state"
                            and not m["msg"]["recording"], timeout=10)
        assert server.recording.recorder is None
        assert "its writer process ended" in caplog.text
        again = await client.call("/record/start", {"name": "next"})
        assert again["values"]["success"], again
        assert (await client.call("/record/stop", timeout=60))["values"]["success"]
    finally:
        await client.close()


async def test_downloads_with_authenticate_answer_the_roles_allowed(make_server, tmp_path):
    """With --authenticate a recording is served to a token whose role may download (issue
    47: authentication switches nothing off), to no one else."""
    from hitrobot_server.state.tokens import add_token, tokens_path

    folder = folder_with_one(tmp_path)
    state = tmp_path / "state"
    viewer = add_token(tokens_path(state), "hall", "viewer", None)
    monitor = add_token(tokens_path(state), "prom", "monitor", None)
    server = await make_server(authenticate=True, record_dir=str(folder), state_dir=str(state))
    status, _h, body = await http(server.port, "GET", "/recordings/ok.mcap")
    assert status == 401 and b"MCAP" not in body
    status, _h, body = await http(server.port, "GET", f"/recordings/ok.mcap?token={monitor}")
    assert status == 403 and b"download" in body and b"MCAP" not in body
    status, _h, body = await http(server.port, "GET", f"/recordings/ok.mcap?token={viewer}")
    assert status == 200 and body.startswith(b"\x89MCAP")


async def test_replay_with_authenticate_asks_the_same_tokens(make_server, tmp_path):
    """Issue 47: /record/replay is not switched off by --authenticate: an operator starts a
    replay, which asks the same tokens (a viewer's token is served there, none is refused)."""
    from websockets.asyncio.client import connect
    from websockets.exceptions import InvalidStatus

    from hitrobot_server.state.tokens import add_token, tokens_path
    from tests.record.test_player import make_recording

    folder = tmp_path / "recordings"
    folder.mkdir()
    await make_recording(folder / "r.mcap")
    state = tmp_path / "state"
    operator = add_token(tokens_path(state), "tablet", "operator", None)
    viewer = add_token(tokens_path(state), "hall", "viewer", None)
    server = await make_server(authenticate=True, record_dir=str(folder), state_dir=str(state))
    client = await WsClient.open(server.port, additional_headers={
        "Authorization": f"Bearer {viewer}"})
    refused = await client.call("/record/replay", {"name": "r"})
    assert not refused["result"] and "lacks the permission 'record'" in refused["values"]
    await client.close()
    client = await WsClient.open(server.port, additional_headers={
        "Authorization": f"Bearer {operator}"})
    reply = await client.call("/record/replay", {"name": "r"}, timeout=60)
    await client.close()
    assert reply["result"] and reply["values"]["success"], reply
    port = reply["values"]["port"]
    try:
        async with connect(f"ws://127.0.0.1:{port}/",
                           subprotocols=["foxglove.websocket.v1"]):
            raise AssertionError("the replay served a Foxglove client without a token")
    except InvalidStatus as exc:
        assert exc.response.status_code == 401
    async with connect(f"ws://127.0.0.1:{port}/?token={viewer}",
                       subprotocols=["foxglove.websocket.v1"]) as ws:
        assert '"serverInfo"' in await ws.recv()

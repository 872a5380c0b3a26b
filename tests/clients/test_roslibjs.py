"""The real roslibjs 2.x (from npm, run by Node) against a live hitrobot-server."""

from __future__ import annotations

import asyncio
import shutil
from pathlib import Path

import pytest

from hitrobot_server.bus.services import STATUS_SUCCEEDED, GoalOutcome
from hitrobot_server.nodes.base import Node

JS = Path(__file__).resolve().parents[1] / "js"
CHECKS = ["pubsub", "png_compression", "cbor_compression", "fragmented_large_message",
          "service_between_clients", "service_failure", "rosapi_and_params", "ros2_action_goal",
          "status_errors_reach_client"]


@pytest.fixture(scope="module")
def node_modules() -> Path:
    if shutil.which("node") is None or not (JS / "node_modules" / "roslib").is_dir():
        raise RuntimeError("roslibjs is not installed: run `npm ci --prefix tests/js` "
                           "(.ci/run does this)")
    return JS


async def test_roslibjs_client_suite(make_server, node_modules):
    server = await make_server(max_message_size=100_000)
    node = Node(server.bus, "/js_test_node")

    async def count(handle):
        for left in (2.0, 1.0, 0.0):
            handle.feedback({"distance_to_goal": left, "speed": 0.5})
            await asyncio.sleep(0.02)
        return GoalOutcome(STATUS_SUCCEEDED, {}, True)

    node.action("/js/count", "nav2_msgs/FollowPath", count)
    await run_checks(node_modules / "roslibjs_client.mjs", server.port, CHECKS, 90)


async def run_checks(script: Path, port: int, checks: list[str], timeout: float,
                     extra: list[str] = ()) -> None:
    """Run a Node script of checks against the server; every named check must say ok."""
    proc = await asyncio.create_subprocess_exec(
        "node", str(script), f"ws://127.0.0.1:{port}", *extra,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT, cwd=script.parent,
    )
    out, _ = await asyncio.wait_for(proc.communicate(), timeout)
    lines = out.decode().splitlines()
    report = {line.split(":")[0].split(" ", 1)[1]: line for line in lines
              if line.startswith(("ok ", "fail "))}
    for name in checks:
        assert report.get(name, "").startswith("ok "), f"{name}: {report.get(name)}\n{out.decode()}"
    assert proc.returncode == 0


TF_CHECKS = ["tfclient_2x_actionlib", "ros2tfclient_2x_action", "tfclient_1x_actionlib",
             "tfclient_1x_republish_service", "rosout_type", "cancel_all_goals_stops_follow_path"]


async def test_roslibjs_tf_clients_and_cancel_all_goals(make_server, node_modules):
    """roslibjs 2.x TFClient and ROS2TFClient, roslibjs 1.4.1 TFClient (actionlib and
    /republish_tfs forms) follow the driving robot; cancelAllGoals stops /follow_path."""
    if not (node_modules / "node_modules" / "roslib1").is_dir():
        raise RuntimeError("roslib 1.4.1 is not installed: run `npm ci --prefix tests/js`")
    server = await make_server(robot="sim")
    await run_checks(node_modules / "roslibjs_tf.mjs", server.port, TF_CHECKS, 120)


async def test_roslibjs_reassembles_fragments_interleaved_with_another_topic(
    make_server, node_modules
):
    """The outbox sends a big message's fragments in turn with a small topic's messages
    (``delay_between_messages`` sends every frame through it); roslibjs joins them."""
    server = await make_server(max_message_size=20_000, delay_between_messages=0.002)
    await run_checks(node_modules / "roslibjs_interleave.mjs", server.port,
                     ["fragments_interleaved_with_another_topic"], 60)

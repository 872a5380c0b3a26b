"""ros-mcp, the MCP server agents use to drive robots over rosbridge, against a real server
(issue 49 item 9). Its real path: ``python -m ros_mcp.main`` over MCP stdio, driven by the
``mcp`` client library it depends on, each tool called as an agent calls it, against a
``hitrobot-server`` process with the simulated robot on a loopback port.

Tools that do not reach the server are left out: ``get_verified_robot_spec`` and
``get_verified_robots_list`` (files shipped with ros-mcp), ``view_saved_image`` (a local
file). ``ping_robots`` and ``connect_to_robot`` run the system ``ping``, which a machine may
lack; their port check is what is asserted.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import json
import sys
import threading
import time

import pytest
from mcp import ClientSession, StdioServerParameters
from mcp.client.stdio import stdio_client

from tests.helpers import ServerProcess

CALL_TIMEOUT = 60.0
NAV = "/intelligent_navigate_to_pose"
NAV_TYPE = "daystar_navigation_msgs/action/IntelligentNavitateToPose"
TWIST = "geometry_msgs/Twist"
STATUS_EXECUTING, STATUS_CANCELED = 2, 5  # action_msgs/GoalStatus


class Agent:
    """One ros-mcp process and its MCP session, on a thread of its own: ``call`` is a tool
    call as an agent makes it, answered with the tool's JSON result."""

    def __init__(self, errlog) -> None:
        self._loop = asyncio.new_event_loop()
        self._requests: asyncio.Queue | None = None
        self._ready: concurrent.futures.Future = concurrent.futures.Future()
        self._params = StdioServerParameters(command=sys.executable, args=["-m", "ros_mcp.main"])
        self._errlog = errlog
        self._thread = threading.Thread(target=self._loop.run_until_complete,
                                        args=(self._serve(),), daemon=True)
        self._thread.start()
        self._ready.result(CALL_TIMEOUT)

    async def _serve(self) -> None:
        """The session lives in one task (its context managers exit where they entered)."""
        try:
            async with stdio_client(self._params, errlog=self._errlog) as (read, write), \
                    ClientSession(read, write) as session:
                await session.initialize()
                self._requests = asyncio.Queue()
                self._ready.set_result(None)
                while (item := await self._requests.get()) is not None:
                    tool, args, answer = item
                    try:
                        answer.set_result(await session.call_tool(tool, args))
                    except Exception as exc:  # handed to the caller
                        answer.set_exception(exc)
        except Exception as exc:
            if not self._ready.done():
                self._ready.set_exception(exc)
            raise

    def call(self, tool: str, **args) -> dict | list:
        answer: concurrent.futures.Future = concurrent.futures.Future()
        self._loop.call_soon_threadsafe(self._requests.put_nowait, (tool, args, answer))
        result = answer.result(CALL_TIMEOUT)
        assert not result.isError, f"{tool}: {result.content}"
        found = result.structuredContent
        if isinstance(found, dict) and set(found) == {"result"}:  # a list, wrapped
            found = found["result"]
        if found is None:
            found = [json.loads(c.text) for c in result.content]
        return found

    def close(self) -> None:
        self._loop.call_soon_threadsafe(self._requests.put_nowait, None)
        self._thread.join(30)


@pytest.fixture(scope="module")
def server():
    proc = ServerProcess(robot="sim")
    yield proc
    proc.stop()


@pytest.fixture(scope="module")
def agent(server, tmp_path_factory):
    with open(tmp_path_factory.mktemp("ros-mcp") / "stderr.log", "w") as errlog:
        a = Agent(errlog)
        connected = a.call("connect_to_robot", ip="127.0.0.1", port=server.port)
        assert connected["connectivity_test"]["port_check"]["open"] is True
        assert "warning" not in connected  # its ROS version detection found ours
        yield a
        a.close()


def test_detect_ros_version(agent):
    assert agent.call("detect_ros_version") == {"version": "1", "distro": "noetic"}


def test_ping_robots(agent, server):
    (result,) = agent.call("ping_robots", targets=[{"ip": "127.0.0.1", "port": server.port}])[
        "results"]
    assert result["port_check"]["open"] is True


def test_topics_and_their_types(agent):
    topics = agent.call("get_topics")["topics"]
    assert {"/odom", "/scan", "/map", "/cmd_vel"} <= set(topics)
    assert agent.call("get_topic_type", topic="/odom")["type"] == "nav_msgs/Odometry"
    details = agent.call("get_topic_details", topic="/cmd_vel")
    assert details["type"] == TWIST
    assert "/slamware_ros_sdk_server_node" in details["subscribers"]
    fields = agent.call("get_message_details", message_type=TWIST)["structure"]
    assert fields[TWIST]["fields"] == {"linear": "geometry_msgs/Vector3",
                                       "angular": "geometry_msgs/Vector3"}


def test_subscribe_once_and_for_a_duration(agent):
    odom = agent.call("subscribe_once", topic="/odom", msg_type="nav_msgs/Odometry",
                      timeout=10)["msg"]
    assert odom["header"]["frame_id"] == "/odom"
    got = agent.call("subscribe_for_duration", topic="/odom", msg_type="nav_msgs/Odometry",
                     duration=1.0, max_messages=3)
    head = got[0] if isinstance(got, list) else got
    assert head["collected_count"] >= 1 and head["status_errors"] == []


def _x(agent) -> float:
    odom = agent.call("subscribe_once", topic="/odom", msg_type="nav_msgs/Odometry", timeout=10)
    return odom["msg"]["pose"]["pose"]["position"]["x"]


def test_publish_to_cmd_vel_drives_the_robot(agent):
    forward = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    before = _x(agent)
    once = agent.call("publish_once", topic="/cmd_vel", msg_type=TWIST, msg=forward)
    assert once["success"] is True
    timed = agent.call("publish_for_durations", topic="/cmd_vel", msg_type=TWIST,
                       messages=[forward], durations=[1.0], rate_hz=10)
    assert timed["success"] is True and timed["errors"] == []
    deadline = time.monotonic() + 20
    while _x(agent) < before + 0.05 and time.monotonic() < deadline:
        pass  # each read is a round trip to the server (bounded by the deadline)
    assert _x(agent) >= before + 0.05


def test_services_listed_described_and_called(agent):
    services = agent.call("get_services")["services"]
    assert {"/rosapi/get_time", f"{NAV}/_action/send_goal"} <= set(services)
    assert agent.call("get_service_type", service="/rosapi/get_time")["type"] == "rosapi/GetTime"
    details = agent.call("get_service_details", service="/rosapi/get_time")
    assert details["response"]["fields"] == {"secs": "int32", "nsecs": "int32"}
    assert details["providers"] == ["/rosapi"]
    called = agent.call("call_service", service_name="/rosapi/get_time",
                        service_type="rosapi/GetTime", request={})
    assert called["success"] is True and called["result"]["time"]["secs"] > 0


def test_nodes(agent):
    nodes = agent.call("get_nodes")["nodes"]
    assert {"/rosapi", "/slamware_ros_sdk_server_node"} <= set(nodes)
    details = agent.call("get_node_details", node="/slamware_ros_sdk_server_node")
    assert "/cmd_vel" in details["subscribers"]


def test_parameters_of_the_server_and_of_a_node(agent):
    assert agent.call("get_parameter", name="/rosdistro")["successful"] is True
    node = agent.call("get_parameters", node_name="/slamware_ros_sdk_server_node")
    assert "/slamware_ros_sdk_server_node:map_frame" in node["parameters"]
    name = "/agent_test/speed"
    assert agent.call("set_parameter", name=name, value="0.5")["successful"] is True
    assert agent.call("has_parameter", name=name)["exists"] is True
    assert agent.call("get_parameter", name=name)["value"] == "0.5"
    assert agent.call("get_parameter_details", name=name)["type"] == "float"
    assert agent.call("delete_parameter", name=name)["successful"] is True
    assert agent.call("has_parameter", name=name)["exists"] is False


def test_actions_listed_and_described(agent):
    actions = agent.call("get_actions")["actions"]
    assert {NAV, "/move_base", "/follow_path", "/compute_path_to_pose"} <= set(actions)
    details = agent.call("get_action_details", action=NAV, action_type=NAV_TYPE)
    assert set(details["goal"]["fields"]) == {"travel_params", "pose", "should_stop"}
    assert set(details["feedback"]["fields"]) == {"current_pose", "current_state"}


def _statuses(agent) -> list[dict]:
    return agent.call("get_action_status", action_name=NAV)["active_goals"]


def test_a_goal_sent_outlives_the_call_and_is_cancelled_by_its_id(agent):
    """ros-mcp's call gives up after its timeout and closes its connection; the goal drives
    on (reported executing, with real stamps) until a later call cancels it by its id."""
    goal = {"pose": {"header": {"frame_id": "map"},
                     "pose": {"position": {"x": 12.0, "y": 8.0, "z": 0.0},
                              "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}
    sent = agent.call("send_action_goal", action_name=NAV, action_type=NAV_TYPE, goal=goal,
                      timeout=1.0)
    assert sent["feedback_count"] >= 1 and "timed out" in sent["error"]
    running = [g for g in _statuses(agent) if g["status"] == STATUS_EXECUTING]
    assert len(running) == 1 and float(running[0]["timestamp"]) > 0
    cancelled = agent.call("cancel_action_goal", action_name=NAV, goal_id=sent["goal_id"])
    assert cancelled["success"] is True
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:  # each read a round trip (bounded)
        if [g["status"] for g in _statuses(agent)] == [STATUS_CANCELED]:
            break
    assert [g["status"] for g in _statuses(agent)] == [STATUS_CANCELED]

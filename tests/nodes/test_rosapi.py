"""rosapi describes every type it names: a client that lists the topics and services can look
each one up (roslibjs ``getMessageDetails``, Foxglove's raw definitions, rosbridge's
``topics_and_raw_types``), action feedback and status types included."""

from __future__ import annotations

import re

import pytest

from tests.helpers import WsClient

BUILTINS = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
            "int64", "uint64", "float32", "float64", "string", "time", "duration"}
BLOCK = re.compile(r"^={80}\nMSG: (\S+)\n", re.MULTILINE)


@pytest.fixture
async def client(make_server, tmp_path):
    server = await make_server(robot="sim", demo_services=True, map_dir=str(tmp_path / "maps"))
    c = await WsClient.open(server.port)
    yield c
    await c.close()


async def details(client: WsClient, service: str, type_name: str) -> list[dict]:
    reply = await client.call(service, {"type": type_name})
    assert reply["result"] is True, f"{service} {type_name}: {reply['values']}"
    return reply["values"]["typedefs"]


def raw_type_names(text: str) -> tuple[list[str], list[str]]:
    """The types a ROS 1 full definition (``gendeps --cat``) defines, and those it uses."""
    parts = BLOCK.split(text)
    defined = parts[1::2]
    used = []
    for body in parts[0::2]:
        for line in body.splitlines():
            line = line.split("#", 1)[0].strip()
            if not line or "=" in line:  # blank, comment or constant
                continue
            base = re.sub(r"\[\d*\]$", "", line.split()[0])
            if base not in BUILTINS:
                used.append(base)
    return defined, used


def resolves(name: str, defined: list[str]) -> bool:
    """How a ROS 1 reader resolves a field type: full name, Header, or a short name of one of
    the defined types."""
    if name == "Header":
        return "std_msgs/Header" in defined
    return name in defined or any(d.endswith(f"/{name}") for d in defined)


async def test_every_listed_topic_type_is_described(client):
    listed = (await client.call("/rosapi/topics_and_raw_types"))["values"]
    topics = dict(zip(listed["topics"], listed["types"], strict=True))
    raw = dict(zip(listed["topics"], listed["typedefs_full_text"], strict=True))
    # the interfaces the issue named are listed, with the type names rosapi gives them
    assert topics["/follow_path/_action/feedback"] == "nav2_msgs/FollowPath_FeedbackMessage"
    assert topics["/follow_path/_action/status"] == "action_msgs/GoalStatusArray"
    assert topics["/fibonacci/_action/feedback"] == "example_interfaces/Fibonacci_FeedbackMessage"
    plain = (await client.call("/rosapi/topics"))["values"]
    assert dict(zip(plain["topics"], plain["types"], strict=True)) == topics

    seen: set[str] = set()
    for topic, type_name in topics.items():
        assert (await client.call("/rosapi/topic_type", {"topic": topic}))["values"]["type"] \
            == type_name
        defs = await details(client, "/rosapi/message_details", type_name)
        assert defs[0]["type"] == type_name, topic
        described = {d["type"] for d in defs}
        for d in defs:  # every field's type is described in the same answer
            for field_type in d["fieldtypes"]:
                assert field_type in BUILTINS or field_type in described, (topic, field_type)
            seen.add(d["type"])
        # the raw definition (Foxglove, rosbridge's topics_and_raw_types) is complete
        defined, used = raw_type_names(raw[topic])
        for name in used:
            assert resolves(name, defined), f"{topic}: {name} has no MSG: block"
        fields = [f for d in defs[:1] for f, n in zip(d["fieldnames"], d["fieldtypes"],
                                                      strict=True) if n]
        body = BLOCK.split(raw[topic])[0]
        for field_name in fields:
            assert re.search(rf"^\S+ {re.escape(field_name)}\b", body, re.MULTILINE), \
                (topic, field_name)
    # each nested type, looked up by the name rosapi gave it, is described too
    for type_name in sorted(seen - BUILTINS):  # time/duration get a synthetic typedef
        assert (await details(client, "/rosapi/message_details", type_name))[0]["type"] \
            == type_name


async def test_every_listed_service_type_is_described(client):
    services = (await client.call("/rosapi/services"))["values"]["services"]
    assert "/follow_path/_action/send_goal" in services and "/add_two_ints" in services
    for service in services:
        type_name = (await client.call("/rosapi/service_type",
                                       {"service": service}))["values"]["type"]
        assert type_name, service
        for op in ("/rosapi/service_request_details", "/rosapi/service_response_details"):
            assert await details(client, op, type_name), (service, op)

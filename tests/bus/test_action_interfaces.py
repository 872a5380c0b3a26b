"""Every bus action's ROS 2 hidden services and topics, wired to the same goals."""

from __future__ import annotations

import asyncio

import pytest

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.errors import BusError
from hitrobot_server.bus.services import (
    STATUS_CANCELED,
    STATUS_EXECUTING,
    STATUS_SUCCEEDED,
    STATUS_UNKNOWN,
    GoalOutcome,
)
from hitrobot_server.types.convert import from_json
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import until

ACTION = "/drive"
UUID_A, UUID_B = bytes(range(16)), bytes(range(16, 32))


@pytest.fixture
def bus() -> Bus:
    return Bus(TypeRegistry.default(), unregister_timeout=0)


@pytest.fixture
def served(bus):
    """``/drive`` (nav2 FollowPath): one feedback, then runs until cancelled or released."""
    release = asyncio.Event()

    async def handler(handle):
        handle.feedback({"distance_to_goal": 1.5, "speed": 0.2})
        cancelled = asyncio.ensure_future(handle.cancelled.wait())
        released = asyncio.ensure_future(release.wait())
        await asyncio.wait([cancelled, released], return_when=asyncio.FIRST_COMPLETED)
        cancelled.cancel()
        released.cancel()
        if handle.cancelled.is_set():
            return GoalOutcome(STATUS_CANCELED, {"result": {}}, True)
        return GoalOutcome(STATUS_SUCCEEDED, {"result": {}}, True)

    bus.advertise_action(ACTION, "nav2_msgs/FollowPath", "provider", "/driver", handler)
    return release


def collect(bus: Bus, topic: str) -> list[dict]:
    got: list[dict] = []
    bus.subscribe(topic, None, f"watch:{topic}", "/watcher", lambda m: got.append(m.msg))
    return got


async def call(bus: Bus, suffix: str, request: dict) -> dict:
    """Call a hidden service with the request completed as a session would (defaults)."""
    name = f"{ACTION}/_action/{suffix}"
    full, _ = from_json(bus.service(name).stype.request, request, bus.types)
    return await bus.call_service(name, full)


async def send(bus: Bus, uuid: bytes) -> dict:
    return await call(bus, "send_goal", {"goal_id": {"uuid": list(uuid)},
                                         "goal": {"controller_id": "x"}})


async def test_send_goal_feedback_status_and_get_result(bus, served):
    feedback = collect(bus, f"{ACTION}/_action/feedback")
    status = collect(bus, f"{ACTION}/_action/status")
    reply = await send(bus, UUID_A)
    assert reply["accepted"] is True and reply["stamp"]["secs"] > 1_600_000_000
    await until(lambda: feedback, "feedback")
    assert feedback[0] == {"goal_id": {"uuid": UUID_A},
                           "feedback": {"distance_to_goal": 1.5, "speed": 0.2}}
    assert status[-1]["status_list"][0]["status"] == STATUS_EXECUTING
    assert status[-1]["status_list"][0]["goal_info"]["goal_id"]["uuid"] == UUID_A
    assert (await send(bus, UUID_A))["accepted"] is False  # the same id is still running
    result = asyncio.ensure_future(
        call(bus, "get_result", {"goal_id": {"uuid": list(UUID_A)}}))
    served.set()
    assert (await result)["status"] == STATUS_SUCCEEDED
    assert status[-1]["status_list"][0]["status"] == STATUS_SUCCEEDED
    again = await call(bus, "get_result", {"goal_id": {"uuid": list(UUID_A)}})
    assert again == {"status": STATUS_SUCCEEDED, "result": {"result": {}}}
    unknown = await call(bus, "get_result", {"goal_id": {"uuid": list(UUID_B)}})
    assert unknown["status"] == STATUS_UNKNOWN


async def test_goals_sent_with_the_protocol_op_are_seen_and_cancel_all_stops_them(bus, served):
    feedback = collect(bus, f"{ACTION}/_action/feedback")
    handle, task = bus.start_goal(ACTION, {"controller_id": "op"})
    await until(lambda: feedback, "feedback of a protocol goal")
    assert feedback[0]["goal_id"]["uuid"] == handle.uuid
    await send(bus, UUID_B)
    reply = await call(bus, "cancel_goal", {})  # cancelAllGoals
    assert reply["return_code"] == 0
    assert {g["goal_id"]["uuid"] for g in reply["goals_canceling"]} == {handle.uuid, UUID_B}
    assert (await task).status == STATUS_CANCELED
    result = await call(bus, "get_result", {"goal_id": {"uuid": list(UUID_B)}})
    assert result["status"] == STATUS_CANCELED


async def test_cancel_one_goal_unknown_and_finished_ids(bus, served):
    await send(bus, UUID_A)
    await send(bus, UUID_B)
    cancel = "cancel_goal"
    reply = await call(bus, cancel, {"goal_info": {"goal_id": {"uuid": list(UUID_A)}}})
    assert [g["goal_id"]["uuid"] for g in reply["goals_canceling"]] == [UUID_A]
    await call(bus, "get_result", {"goal_id": {"uuid": list(UUID_A)}})
    reply = await call(bus, cancel, {"goal_info": {"goal_id": {"uuid": list(UUID_A)}}})
    assert reply == {"return_code": 3, "goals_canceling": []}  # already terminated
    reply = await call(bus, cancel, {"goal_info": {"goal_id": {"uuid": [9] * 16}}})
    assert reply == {"return_code": 2, "goals_canceling": []}  # unknown goal
    served.set()
    await call(bus, "get_result", {"goal_id": {"uuid": list(UUID_B)}})
    assert (await call(bus, cancel, {}))["return_code"] == 1  # nothing left to cancel


async def test_interfaces_come_and_go_with_the_action(bus, served):
    names = [f"{ACTION}/_action/{s}" for s in ("send_goal", "cancel_goal", "get_result")]
    assert all(bus.service(n) is not None for n in names)
    assert bus.service(names[0]).type_name == "nav2_msgs/action/FollowPath_SendGoal"
    assert bus.topic(f"{ACTION}/_action/status").type_name == "action_msgs/msg/GoalStatusArray"
    assert bus.topic(f"{ACTION}/_action/feedback").type_name == (
        "nav2_msgs/action/FollowPath_FeedbackMessage")
    await send(bus, UUID_A)
    waiting = asyncio.ensure_future(
        call(bus, "get_result", {"goal_id": {"uuid": list(UUID_A)}}))
    await asyncio.sleep(0)  # let the call reach the service and wait for the outcome
    assert bus.unadvertise_action(ACTION, "provider")
    assert all(bus.service(n) is None for n in names)
    assert bus.topic(f"{ACTION}/_action/status") is None
    with pytest.raises(BusError, match="went away"):  # a pending get_result is answered
        await asyncio.wait_for(waiting, 2)

"""Carrying a topic-borne request out, sans-I/O: which answer each robot outcome becomes."""

from __future__ import annotations

import asyncio
import logging

import pytest

from hitrobot_server.bus.requests import Reply
from hitrobot_server.bus.topics import RequestRejected
from hitrobot_server.nodes.ground.requests import (
    NOT_CONNECTED,
    answer,
    require_robot,
    robot_error,
)
from hitrobot_server.robot.backend import BackendError, NotConnectedError, UnsupportedError


class StoreTrouble(Exception):
    """A node's own request error (the map manager's store errors, say)."""


def heard() -> tuple[list[tuple[str, str]], Reply]:
    answers: list[tuple[str, str]] = []
    return answers, Reply(lambda level, text: answers.append((level, text)))


async def outcome(work, what: str = "save_map", **kwargs) -> list[tuple[str, str]]:
    answers, reply = heard()
    await answer(reply, what, work, **kwargs)
    return answers


async def returns(value):
    return value


async def raises(exc: BaseException):
    raise exc


async def test_the_text_work_returns_is_the_ok_answer_and_none_answers_nothing():
    assert await outcome(returns("saved map 'a'")) == [("info", "save_map: saved map 'a'")]
    assert await outcome(returns(None)) == []
    assert await outcome(returns("")) == []


async def test_an_offline_robot_is_worded_the_same_whatever_the_exception_says():
    got = await outcome(raises(NotConnectedError("GET /pose: connection refused")))
    assert got == [("error", f"save_map: {NOT_CONNECTED}")]


async def test_a_robot_error_reaches_the_publisher_with_its_own_text():
    assert await outcome(raises(BackendError("the robot has no map to save yet")), "cmd_vel") \
        == [("error", "cmd_vel: the robot has no map to save yet")]
    assert await outcome(raises(UnsupportedError("no power control")), "shutdown") \
        == [("error", "shutdown: no power control")]


async def test_known_request_errors_read_like_robot_errors_and_others_are_failures(caplog):
    assert await outcome(raises(StoreTrouble("disk full")), known=(StoreTrouble,)) \
        == [("error", "save_map: disk full")]
    with caplog.at_level(logging.ERROR, logger="hitrobot_server.nodes.ground.requests"):
        got = await outcome(raises(StoreTrouble("disk full")))
    assert got == [("error", "save_map failed: disk full")]
    assert [r.getMessage() for r in caplog.records] == ["save_map failed"]


async def test_an_unlabelled_request_with_its_own_failure_label():
    """``/initialpose``: an offline robot is plain, another robot error is labelled."""
    assert await outcome(raises(NotConnectedError()), "", failed="set pose failed") \
        == [("error", NOT_CONNECTED)]
    assert await outcome(raises(BackendError("pose rejected")), "", failed="set pose failed") \
        == [("error", "set pose failed: pose rejected")]
    assert await outcome(raises(KeyError("x")), "", failed="set pose failed") \
        == [("error", "set pose failed: 'x'")]


async def test_a_cancelled_request_is_not_answered():
    answers, reply = heard()
    started = asyncio.Event()

    async def follow_the_robot():
        started.set()
        await asyncio.Event().wait()  # until the node stops

    task = asyncio.ensure_future(answer(reply, "move_to", follow_the_robot()))
    await started.wait()
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    assert answers == []


class Robot:
    def __init__(self, connected: bool):
        self.connected = connected


def test_an_offline_robot_refuses_the_request_at_once():
    require_robot(Robot(True), "go_home")
    with pytest.raises(RequestRejected, match=f"^go_home: {NOT_CONNECTED}$"):
        require_robot(Robot(False), "go_home")
    with pytest.raises(RequestRejected, match=f"^{NOT_CONNECTED}$"):
        require_robot(Robot(False), "")


def test_robot_error_words_only_the_offline_robot():
    assert robot_error(NotConnectedError("socket closed")) == NOT_CONNECTED
    assert robot_error(NotConnectedError("socket closed"), "robot pose unavailable") \
        == NOT_CONNECTED
    assert robot_error(BackendError("no such POI")) == "no such POI"
    assert robot_error(BackendError("stuck"), "the robot refused waypoint 2") \
        == "the robot refused waypoint 2: stuck"

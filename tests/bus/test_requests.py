"""A request's reply handle, sans-I/O: what each answer becomes for its publisher."""

from __future__ import annotations

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.requests import Reply
from hitrobot_server.bus.topics import RequestRejected
from hitrobot_server.types.registry import TypeRegistry


def heard() -> tuple[list[tuple[str, str]], Reply]:
    answers: list[tuple[str, str]] = []
    return answers, Reply(lambda level, text: answers.append((level, text)))


def test_each_answer_reaches_the_publisher_at_its_status_level():
    answers, reply = heard()
    reply.ok("move_to: arrived")
    reply.info("move_to: cancelled")
    reply.warn("no goal with id 'g'")
    reply.fail("move_to: the robot is not connected")
    reply.send("warning", "relayed as is")
    assert answers == [("info", "move_to: arrived"), ("info", "move_to: cancelled"),
                       ("warning", "no goal with id 'g'"),
                       ("error", "move_to: the robot is not connected"),
                       ("warning", "relayed as is")]


def test_a_request_published_without_a_way_back_answers_nobody():
    reply = Reply()
    reply.ok("done")  # an in-process publisher's request: nothing to tell, nothing raised
    seen: list[tuple[str, str]] = []
    reply.observe(lambda level, text: seen.append((level, text)))
    reply.fail("refused")
    assert seen == [("error", "refused")]


def test_an_observer_hears_the_answer_before_the_publisher():
    order: list[str] = []
    reply = Reply(lambda level, text: order.append(f"publisher {level} {text}"))
    reply.observe(lambda level, text: order.append(f"observer {level} {text}"))
    reply.ok("load_map: loaded map 'a'")
    assert order == ["observer info load_map: loaded map 'a'",
                     "publisher info load_map: loaded map 'a'"]


def test_every_published_message_carries_a_reply_to_its_publisher():
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    bus.advertise("/cmd", "std_msgs/String", "pub", "/n")
    answers: list[tuple[str, str]] = []

    def refuse(message):
        raise RequestRejected("not now")

    bus.subscribe("/cmd", None, "refuse", "/node", refuse)
    message = bus.publish("/cmd", {"data": "x"},
                          reply=lambda level, text: answers.append((level, text)))
    message.reply.ok("done after all")
    silent = bus.publish("/cmd", {"data": "y"})
    silent.reply.fail("nobody hears this")
    assert answers == [("error", "not now"), ("info", "done after all")]

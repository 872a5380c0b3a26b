"""One client's topic-name check, sans I/O: canonical names, --topics-glob, a bounded memory."""

import pytest

from hitrobot_server.bus.names import GlobFilter
from hitrobot_server.protocol.errors import ProtocolError
from hitrobot_server.session.rosbridge.publish import TopicNames


def test_a_spelling_is_checked_once_and_answered_from_memory():
    names = TopicNames(GlobFilter(["/robot/*"]))
    assert names.check("subscribe", "robot/odom", "s1") == "/robot/odom"
    assert names.known == {"robot/odom": "/robot/odom"}
    names.allowed = GlobFilter(["/nothing"])  # a remembered spelling is not checked again
    assert names.check("publish", "robot/odom", None) == "/robot/odom"


def test_invalid_and_denied_names_are_errors_naming_the_op():
    names = TopicNames(GlobFilter(["/robot/*"]))
    with pytest.raises(ProtocolError) as invalid:
        names.check("publish", "/bad name", "p1")
    assert invalid.value.msg == "publish: field 'topic' is not a valid topic name: '/bad name'"
    assert invalid.value.id == "p1"
    with pytest.raises(ProtocolError) as denied:
        names.check("advertise", "/secret", 3)
    assert denied.value.msg == "advertise: topic '/secret' is not allowed by --topics-glob"
    assert not names.known


def test_the_memory_is_bounded():
    names = TopicNames(GlobFilter())
    for i in range(TopicNames.LIMIT + 10):
        assert names.check("subscribe", f"/t{i}", None) == f"/t{i}"
    assert len(names.known) == TopicNames.LIMIT

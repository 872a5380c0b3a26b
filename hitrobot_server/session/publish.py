"""``advertise``, ``unadvertise`` and ``publish`` from a client."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..bus.encoded import VERBATIM_MIN, Seed, verbatim_publish
from ..bus.names import canonical, valid_name
from ..protocol.errors import ProtocolError
from ..types.convert import from_json_verbatim

if TYPE_CHECKING:
    from .session import Session


def check_topic_name(session: Session, op: str, topic: str, op_id) -> str:
    """Canonical name, or a status error naming the field when unusable or glob-denied.

    Accepted spellings are remembered per client: a 1 kHz publisher should not pay for
    validation and glob matching on every message.
    """
    name = session.topic_names.get(topic)
    if name is not None:
        return name
    if not valid_name(topic):
        raise ProtocolError(f"{op}: field 'topic' is not a valid topic name: {topic!r}", op_id)
    name = canonical(topic)
    if not session.settings.topics_filter.allows(name):
        raise ProtocolError(f"{op}: topic '{name}' is not allowed by --topics-glob", op_id)
    if len(session.topic_names) < 4096:  # bounded: a client cycling names cannot grow it
        session.topic_names[topic] = name
    return name


class PublishOps:
    """This client's publisher registrations: advertise ids per topic, as rosbridge keeps them."""

    def __init__(self, session: Session):
        self.session = session
        self.ads: dict[str, set] = {}

    def advertise(self, msg: dict) -> None:
        s = self.session
        name = check_topic_name(s, "advertise", msg["topic"], msg.get("id"))
        topic = s.bus.advertise(name, msg["type"], s, s.node, latch=bool(msg.get("latch", False)))
        self.ads.setdefault(topic.name, set()).add(msg.get("id"))
        s.status("info", f"advertised '{name}' as {s.types.short(topic.type_name)}", msg.get("id"))

    def unadvertise(self, msg: dict) -> None:
        s = self.session
        name = check_topic_name(s, "unadvertise", msg["topic"], msg.get("id"))
        ids = self.ads.get(name)
        if ids is None:
            what = "does not exist" if s.bus.topic(name) is None else "is not advertised by you"
            s.status("warning", f"unadvertise: topic '{name}' {what}", msg.get("id"))
            return
        op_id = msg.get("id")
        if op_id is not None and op_id in ids and len(ids) > 1:
            ids.discard(op_id)
            return
        del self.ads[name]
        s.bus.unadvertise(name, s)
        s.status("info", f"unadvertised '{name}'", op_id)

    def publish(self, msg: dict) -> None:
        s = self.session
        op_id = msg.get("id")
        name = check_topic_name(s, "publish", msg["topic"], op_id)
        topic = s.bus.topic(name)
        if topic is None:
            raise ProtocolError(
                f"publish: cannot infer the type of topic '{name}': it does not exist; "
                "advertise it with a type first",
                op_id,
            )
        if name not in self.ads:  # implicit advertise, like rosbridge
            s.bus.advertise(name, None, s, s.node, latch=bool(msg.get("latch", False)))
            self.ads[name] = {None}
        body = msg.get("msg", {})
        if topic.mtype.fields and len(topic.mtype.fields) == 1 and not isinstance(body, dict):
            body = {topic.mtype.fields[0].name: body}  # seed 4.1: "msg": <string> on /cmd_string
        value, missing, verbatim = from_json_verbatim(topic.mtype, body, s.types)
        seed = None
        if s.frame is not None and len(s.frame) >= VERBATIM_MIN:
            text = None
            if verbatim and body is msg.get("msg"):
                text = verbatim_publish(s.frame, msg)  # the client's text is the outgoing op
            seed = Seed(len(s.frame), msg["topic"], text)  # the op's length: the message's size
        if missing:
            s.status(
                "warning",
                f"publish: message for '{name}' lacks field(s) {', '.join(missing)}; defaults used",
                op_id,
            )

        def reply(level: str, text: str) -> None:
            s.status(level, f"publish to '{name}': {text}", op_id)

        s.bus.publish(name, value, reply=reply, origin=s.origin, seed=seed)

    def close(self) -> None:
        for name in list(self.ads):
            self.session.bus.unadvertise(name, self.session)
        self.ads.clear()

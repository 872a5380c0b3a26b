"""``advertise``, ``unadvertise`` and ``publish`` from a client."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...bus.names import GlobFilter, canonical, valid_name
from ...protocol.errors import MessageId, ProtocolError
from ...protocol.ops import ABSENT, Advertise, Publish, Unadvertise
from ...types.convert import from_json_verbatim
from ...types.generation import is_ros2
from .encodings import seeded
from .verbatim import VERBATIM_MIN, verbatim_publish

if TYPE_CHECKING:
    from .context import OpContext


class TopicNames:
    """One client's accepted topic spellings and their canonical names (its publish and
    subscribe ops share them). Remembered per client: a 1 kHz publisher should not pay for
    validation and glob matching on every message."""

    LIMIT = 4096  # bounded: a client cycling names cannot grow it

    def __init__(self, allowed: GlobFilter):
        self.allowed = allowed  # --topics-glob
        self.known: dict[str, str] = {}

    def check(self, op: str, topic: str, op_id: MessageId) -> str:
        """Canonical name, or a status error naming the field when unusable or glob-denied."""
        name = self.known.get(topic)
        if name is not None:
            return name
        if not valid_name(topic):
            raise ProtocolError(
                f"{op}: field 'topic' is not a valid topic name: {topic!r}", op_id
            )
        name = canonical(topic)
        if not self.allowed.allows(name):
            raise ProtocolError(f"{op}: topic '{name}' is not allowed by --topics-glob", op_id)
        if len(self.known) < self.LIMIT:
            self.known[topic] = name
        return name


class PublishOps:
    """This client's publisher registrations: advertise ids per topic, as rosbridge keeps them."""

    def __init__(self, client: OpContext, topic_names: TopicNames):
        self.client = client
        self.topic_names = topic_names
        self.ads: dict[str, set] = {}

    def advertise(self, op: Advertise) -> None:
        c = self.client
        name = self.topic_names.check("advertise", op.topic, op.id)
        topic = c.bus.advertise(name, op.type, c, c.node, latch=op.latch)
        self.ads.setdefault(topic.name, set()).add(op.id)
        c.status("info", f"advertised '{name}' as {c.bus.types.short(topic.type_name)}", op.id)

    def unadvertise(self, op: Unadvertise) -> None:
        c = self.client
        name = self.topic_names.check("unadvertise", op.topic, op.id)
        ids = self.ads.get(name)
        if ids is None:
            what = "does not exist" if c.bus.topic(name) is None else "is not advertised by you"
            c.status("warning", f"unadvertise: topic '{name}' {what}", op.id)
            return
        op_id = op.id
        if op_id is not None and op_id in ids and len(ids) > 1:
            ids.discard(op_id)
            return
        del self.ads[name]
        c.bus.unadvertise(name, c)
        c.status("info", f"unadvertised '{name}'", op_id)

    def publish(self, op: Publish, frame: str | bytes | None = None) -> None:
        """``frame`` is the op's JSON text when known: it may go out as the outgoing op."""
        c = self.client
        op_id = op.id
        name = self.topic_names.check("publish", op.topic, op_id)
        topic = c.bus.topics.get(name)  # ``name`` is canonical already
        if topic is None:
            raise ProtocolError(
                f"publish: cannot infer the type of topic '{name}': it does not exist; "
                "advertise it with a type first",
                op_id,
            )
        if name not in self.ads:  # implicit advertise, like rosbridge
            c.bus.advertise(name, None, c, c.node, latch=op.latch)
            self.ads[name] = {None}
        body = {} if op.msg is ABSENT else op.msg
        if topic.mtype.fields and len(topic.mtype.fields) == 1 and not isinstance(body, dict):
            body = {topic.mtype.fields[0].name: body}  # seed 4.1: "msg": <string> on /cmd_string
        value, missing, verbatim = from_json_verbatim(topic.mtype, body, c.bus.types)
        seed = None
        if frame is not None:  # the op's length: the message's size (/metrics counts it)
            text = None
            if len(frame) >= VERBATIM_MIN and verbatim and body is op.msg \
                    and not is_ros2(topic.mtype.name):  # (its times)
                text = verbatim_publish(frame, op.raw)  # the client's text is the outgoing op
            seed = seeded(len(frame), op.topic, text)
        if missing:
            c.status(
                "warning",
                f"publish: message for '{name}' lacks field(s) {', '.join(missing)}; defaults used",
                op_id,
            )

        def reply(level: str, text: str) -> None:
            c.status(level, f"publish to '{name}': {text}", op_id)

        c.bus.publish(name, value, reply=reply, origin=c.origin, seed=seed)

    def close(self) -> None:
        for name in list(self.ads):
            self.client.bus.unadvertise(name, self.client)
        self.ads.clear()

"""A recording's ``ros2msg`` schemas against our types: ours are served as ours, others (another
robot's, another version of a package) as the file defines them.

A schema is compared by its fields with the ROS 2 view of our definition (the one our CDR
follows). ROS 2 gives an empty message one ``uint8 structure_needs_at_least_one_member`` (it is
on the wire); a ``.msg`` text of an empty message has no fields at all, so both sides are put
in that one form before they are compared (an empty result such as ``MoveBaseResult`` is the
same type in both spellings).
"""

from __future__ import annotations

from typing import Any

from mcap.records import Channel, Schema
from rosbags.interfaces import Nodetype
from rosbags.typesys import get_types_from_msg

from ..bus.cdr import Ros2Codec
from ..types.registry import MsgType, TypeRegistry, UnknownType

PLACEHOLDER = ("structure_needs_at_least_one_member", (Nodetype.BASE, ("uint8", 0)))

Fielddef = tuple[Any, Any]


class RecordingError(ValueError):
    """A file that cannot be replayed; the text says why."""


def _normal(fielddef: Fielddef) -> Fielddef:
    consts, fields = fielddef
    return consts, (list(fields) or [PLACEHOLDER])


def _references(fields: list) -> list[str]:
    names = []
    for _fname, desc in fields:
        node = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
        if node[0] == Nodetype.NAME:
            names.append(node[1])
    return names


class Schemas:
    """The schemas and channels of one file, and the definitions it brings that are not ours."""

    def __init__(self, types: TypeRegistry):
        self.types = types
        self.codec = Ros2Codec(types)
        self.schemas: dict[int, Schema] = {}
        self.names: dict[int, str] = {}  # channel id → its type
        self.foreign: dict[str, Fielddef] = {}  # definitions the file brings

    def add(self, schema: Schema) -> None:
        self.schemas[schema.id] = schema

    def check(self, channel: Channel) -> None:
        """A channel we can serve: ROS 2 (``ros2msg`` + ``cdr``) with a schema that parses."""
        schema = self.schemas.get(channel.schema_id)
        if schema is None or schema.encoding != "ros2msg" or channel.message_encoding != "cdr":
            found = f"{schema.encoding if schema else 'no'} schema, {channel.message_encoding}"
            raise RecordingError(f"channel {channel.topic} is not ROS 2 ({found}; replay needs "
                                 "ros2msg schemas and cdr messages)")
        try:
            found = get_types_from_msg(schema.data.decode(), schema.name)
        except Exception as exc:
            raise RecordingError(
                f"channel {channel.topic}: its schema {schema.name} cannot be parsed ({exc})"
            ) from None
        for name, fielddef in found.items():
            self._compare(name, _normal(fielddef))
        self.names[channel.id] = schema.name

    def _compare(self, name: str, fielddef: Fielddef) -> None:
        known = self.types.typestore.fielddefs
        if name in known:
            self.codec.type_hash(name)  # our definition, as ROS 2 sees it
            ours = self.codec.store.fielddefs[name]
            if _normal(ours)[1] == fielddef[1]:
                return
        elif name in self.codec.store.fielddefs and (
                _normal(self.codec.store.fielddefs[name])[1] == fielddef[1]):
            self.foreign.setdefault(name, fielddef)  # a ROS 2 type our ROS 1 side lacks
            return
        if self.foreign.setdefault(name, fielddef)[1] != fielddef[1]:
            raise RecordingError(f"the recording defines {name} twice, differently")

    def adopt(self) -> dict[int, MsgType]:
        """Take the file's own definitions into the registry; each channel's type."""
        if self.foreign:
            every = {**self.types.typestore.fielddefs, **self.foreign}
            for name, (_consts, fields) in self.foreign.items():
                for ref in _references(fields):
                    if ref not in every:
                        raise RecordingError(f"the recording's {name} refers to {ref}, which "
                                             "neither it nor this server defines")
            self.types.adopt(self.foreign)
        try:
            return {cid: self.types.msg(name) for cid, name in self.names.items()}
        except UnknownType as exc:
            raise RecordingError(f"a channel's type is unknown: {exc}") from None

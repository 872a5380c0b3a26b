"""Our messages as ROS 2 puts them on the wire: CDR bytes and RIHS01 type hashes (no Zenoh here).

In-process messages are ROS 1 shaped (``Header`` has ``seq``, time is ``{secs, nsecs}``). A ROS 2
node expects the ROS 2 definition of the same type, so every type is looked up in rosbags' ROS 2
Jazzy store first; types ROS 2 does not have (our Slamware, map_messages, actionlib types, ...)
are copied there from our own definitions, so their ``Header``/``time`` fields become ROS 2's
and their hash is a hash of our definition. Conversion is by field name both ways: a field only
one side has is dropped, or filled with its zero value (``seq`` arrives as 0).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore

from ..types.convert import BIG_ARRAY
from ..types.registry import (
    NUMPY_DTYPES,
    ActionType,
    MsgType,
    TypeRegistry,
    replace_definitions,
)
from .cdr_encode import DirectEncoder, Encode

_TIME = frozenset({"builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"})
_ZERO = {"string": "", "bool": False, "float32": 0.0, "float64": 0.0}
_UUID = "unique_identifier_msgs/msg/UUID"
_STAMP = "builtin_interfaces/msg/Time"
_EVENT_INFO = "service_msgs/msg/ServiceEventInfo"
_BYTES = frozenset({"uint8", "char"})
_NUMPY_INTS = frozenset({"int8", "byte", "int16", "uint16", "int32", "uint32", "int64"})
_MISSING = object()

Build = Callable[[Any], Any]


def _name(node: Any) -> tuple[Any, Any]:
    return (Nodetype.NAME, node)


def _base(typ: str) -> tuple[Any, Any]:
    return (Nodetype.BASE, (typ, 0))


def dds_type_name(name: str) -> str:
    """``pkg/msg/Type`` → ``pkg::msg::dds_::Type_`` (the DDS spelling rmw_zenoh keys carry)."""
    pkg, kind, base = name.split("/")
    return f"{pkg}::{kind}::dds_::{base}_"


def ros_type_name(dds: str) -> str | None:
    """Inverse of :func:`dds_type_name`; None for a name not of that form."""
    parts = dds.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        return None
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


_codecs: weakref.WeakKeyDictionary[TypeRegistry, Ros2Codec] = weakref.WeakKeyDictionary()


def codec_for(types: TypeRegistry) -> Ros2Codec:
    """The one codec of a registry, so the CDR kept on a message (``Message.cdr``) is the
    same bytes for the Zenoh link and the Foxglove sessions."""
    codec = _codecs.get(types)
    if codec is None:
        codec = _codecs[types] = Ros2Codec(types)
    return codec


class Ros2Codec:
    """CDR encode/decode and type hashes for the types of one :class:`TypeRegistry`."""

    def __init__(self, types: TypeRegistry):
        self.types = types
        self.store = get_typestore(Stores.ROS2_JAZZY)
        # ROS 2 hashes ServiceEventInfo with ``uint8[16] client_gid``; rosbags spells it char.
        consts, fields = self.store.fielddefs[_EVENT_INFO]
        self.store.fielddefs[_EVENT_INFO] = (
            consts,
            [
                (n, (Nodetype.ARRAY, (_base("uint8"), 16)) if n == "client_gid" else d)
                for n, d in fields
            ],
        )
        replace_definitions(self.store, types.adopted)  # a replayed file's own definitions
        self._hashes: dict[str, str] = {}
        self._definitions: dict[str, str] = {}
        self._enc: dict[str, Build] = {}
        self._dec: dict[str, Build] = {}
        self._direct = DirectEncoder(self._fielddefs)
        self._fast: dict[str, Encode | None] = {}

    # ------------------------------------------------------------------ types
    def _ensure(self, name: str) -> None:
        """Make ``name`` (and what it refers to) known to the ROS 2 store."""
        if name in self.store.fielddefs:
            return
        consts, fields = self.types.typestore.fielddefs[name]
        self.store.register({name: (consts, fields)})
        for _fname, desc in fields:
            node = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
            if node[0] == Nodetype.NAME:
                self._ensure(node[1])

    def _fielddefs(self, name: str) -> list[tuple[str, Any]]:
        self._ensure(name)
        return self.store.fielddefs[name][1]

    def _synthetic(self, name: str, fields: list[tuple[str, Any]]) -> str:
        if name not in self.store.fielddefs:
            self.store.register({name: ([], fields)})
        return name

    def type_hash(self, name: str) -> str:
        """``RIHS01_<sha256>`` of a message type."""
        found = self._hashes.get(name)
        if found is None:
            self._ensure(name)
            found = self._hashes[name] = self.store.hash_rihs01(name)
        return found

    def definition(self, name: str) -> str:
        """The ROS 2 definition (``ros2msg``, dependencies as ``MSG:`` blocks) that the CDR of
        :meth:`encode` follows: what a Foxglove channel carries as its schema."""
        found = self._definitions.get(name)
        if found is None:
            self._ensure(name)
            found = self._definitions[name] = self.store.generate_msgdef(name, ros_version=2)[0]
        return found

    def service_hash(self, name: str) -> str:
        """``RIHS01_<sha256>`` of a service (``pkg/srv/T`` or an action's ``pkg/action/T_X``)."""
        found = self._hashes.get(name)
        if found is None:
            found = self._hashes[name] = self.store.hash_rihs01(self._service_type(name))
        return found

    def _service_type(self, name: str) -> str:
        """The ROS 2 service description (request, response, event) that a service hash covers."""
        req, resp = f"{name}_Request", f"{name}_Response"
        self._ensure(req)
        self._ensure(resp)
        event = self._synthetic(
            f"{name}_Event",
            [
                ("info", _name("service_msgs/msg/ServiceEventInfo")),
                ("request", (Nodetype.SEQUENCE, (_name(req), 1))),
                ("response", (Nodetype.SEQUENCE, (_name(resp), 1))),
            ],
        )
        return self._synthetic(
            name,
            [
                ("request_message", _name(req)),
                ("response_message", _name(resp)),
                ("event_message", _name(event)),
            ],
        )

    def action_parts(self, atype: ActionType) -> dict[str, str]:
        """The ROS 2 services and feedback message an action is made of (``rcl_action``)."""
        a = atype.name
        for part in (atype.goal, atype.result, atype.feedback):
            self._ensure(part.name)
        uuid = _name(_UUID)
        send, result, feedback = f"{a}_SendGoal", f"{a}_GetResult", f"{a}_FeedbackMessage"
        self._synthetic(f"{send}_Request", [("goal_id", uuid), ("goal", _name(atype.goal.name))])
        self._synthetic(f"{send}_Response", [("accepted", _base("bool")), ("stamp", _name(_STAMP))])
        self._synthetic(f"{result}_Request", [("goal_id", uuid)])
        self._synthetic(
            f"{result}_Response",
            [("status", _base("int8")), ("result", _name(atype.result.name))],
        )
        self._synthetic(feedback, [("goal_id", uuid), ("feedback", _name(atype.feedback.name))])
        info = _name("action_msgs/msg/GoalInfo")
        self._synthetic("action_msgs/srv/CancelGoal_Request", [("goal_info", info)])
        self._synthetic(
            "action_msgs/srv/CancelGoal_Response",
            [("return_code", _base("int8")), ("goals_canceling", (Nodetype.SEQUENCE, (info, 0)))],
        )
        return {
            "send_goal": send,
            "get_result": result,
            "feedback": feedback,
            "cancel_goal": "action_msgs/srv/CancelGoal",
        }

    # ------------------------------------------------------------------ CDR
    def encode(self, msg: dict, mtype: MsgType) -> bytes:
        """CDR (little-endian, with the 4-byte encapsulation header) of a canonical message:
        written directly (:mod:`.cdr_encode`), else, for a type or a value that path does not
        take, through a rosbags object (the reference: its error is the one raised)."""
        name = mtype.name
        try:
            fast = self._fast[name]
        except KeyError:
            fast = self._fast[name] = self._direct.encoder(name)
        if fast is not None:
            try:
                return fast(msg)
            except Exception:  # noqa: BLE001 - the reference path below raises its own error
                pass
        return bytes(self.store.serialize_cdr(self._encoder(name)(msg), name))

    def direct(self, mtype: MsgType) -> bool:
        """:meth:`encode` writes this type directly with no message per array element, so
        its CDR costs about a copy of the message's arrays (see ``DirectEncoder.flat``)."""
        return self._direct.flat(mtype.name)

    def decode(self, data: bytes, mtype: MsgType) -> dict:
        """A canonical (ROS 1 shaped) message from ROS 2 CDR bytes of the same type."""
        self._ensure(mtype.name)
        return self._decoder(mtype)(self.store.deserialize_cdr(data, mtype.name))

    def encode_raw(self, obj: Any, name: str) -> bytes:
        """CDR of a rosbags object of a ROS 2 store type (the action envelopes)."""
        return bytes(self.store.serialize_cdr(obj, name))

    def decode_raw(self, data: bytes, name: str) -> Any:
        return self.store.deserialize_cdr(data, name)

    def make(self, name: str, **values: Any) -> Any:
        return self.store.types[name](**values)

    def wrap(self, msg: dict, mtype: MsgType) -> Any:
        """A rosbags object of ``mtype`` (for nesting into an envelope)."""
        return self._encoder(mtype.name)(msg)

    def unwrap(self, obj: Any, mtype: MsgType) -> dict:
        return self._decoder(mtype)(obj)

    def _encoder(self, name: str) -> Build:
        enc = self._enc.get(name)
        if enc is None:
            self._ensure(name)
            cls = self.store.types[name]
            _consts, fields = self.store.fielddefs[name]
            plan = [(fname, self._enc_field(desc)) for fname, desc in fields]

            def enc(msg: Any) -> Any:
                if not isinstance(msg, dict):
                    msg = {}
                return cls(**{f: build(msg.get(f, _MISSING)) for f, build in plan})

            self._enc[name] = enc
        return enc

    def _enc_field(self, desc: Any) -> Build:
        kind = desc[0]
        if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            elem, length = desc[1]
            fixed = length if kind == Nodetype.ARRAY else 0
            if elem[0] == Nodetype.BASE:
                typ = elem[1][0]
                if typ == "string":
                    return lambda v: [""] * fixed if v is _MISSING else list(v)
                dtype = NUMPY_DTYPES[typ]

                def numbers(v: Any) -> np.ndarray:
                    if v is _MISSING:
                        return np.zeros(fixed, dtype=dtype)
                    if isinstance(v, bytes | bytearray | memoryview):
                        return np.frombuffer(v, dtype=dtype)
                    return np.asarray(v, dtype=dtype)  # a float array's None is NaN

                return numbers
            one = self._enc_field(elem)
            return lambda v: (
                [one(_MISSING) for _ in range(fixed)] if v is _MISSING else [one(x) for x in v]
            )
        if kind == Nodetype.NAME:
            sub = desc[1]
            if sub in _TIME:
                cls = self.store.types[sub]
                return lambda v: (
                    cls(sec=0, nanosec=0)
                    if v is _MISSING
                    else cls(
                        sec=int(v.get("secs", v.get("sec", 0))),
                        nanosec=int(v.get("nsecs", v.get("nanosec", 0))),
                    )
                )
            return lambda v, sub=sub: self._encoder(sub)({} if v is _MISSING else v)
        typ = desc[1][0]
        zero = _ZERO.get(typ, 0)
        return lambda v: zero if v is _MISSING or v is None else v

    def _decoder(self, mtype: MsgType) -> Build:
        dec = self._dec.get(mtype.name)
        if dec is None:
            plan = [(f.name, self._dec_field(f.type, f.is_msg, f.array)) for f in mtype.fields]

            def dec(obj: Any) -> dict:
                return {f: read(getattr(obj, f, _MISSING)) for f, read in plan}

            self._dec[mtype.name] = dec
        return dec

    def _dec_field(self, typ: str, is_msg: bool, array: int | None) -> Build:
        if array is not None and not is_msg and typ not in ("time", "duration", "string"):
            if typ in _BYTES:
                return lambda v: bytes(array or 0) if v is _MISSING else bytes(np.asarray(v).data)
            if typ in _NUMPY_INTS:  # big integer arrays stay numpy, as convert.py keeps them

                def ints(v: Any) -> Any:
                    if v is _MISSING:
                        return [0] * (array or 0)
                    arr = np.asarray(v)
                    return arr.copy() if arr.size >= BIG_ARRAY else arr.tolist()

                return ints

            def floats(v: Any) -> Any:  # big ones stay numpy: a 50 MB scan, not 12M floats
                if v is _MISSING:
                    return [0] * (array or 0)
                arr = np.asarray(v)
                big = arr.size >= BIG_ARRAY and typ in ("float32", "float64")
                return np.array(arr) if big else arr.tolist()

            return floats
        if is_msg:
            sub = self.types.msg(typ)
            one: Build = lambda v: self._decoder(sub)(v)  # noqa: E731
        elif typ in ("time", "duration"):
            one = lambda v: {"secs": int(v.sec), "nsecs": int(v.nanosec)}  # noqa: E731
        else:
            zero = _ZERO.get(typ, 0)
            one = lambda v: zero if v is _MISSING else v  # noqa: E731
        if array is None:
            if is_msg:
                return lambda v: self._decoder(sub)(None) if v is _MISSING else one(v)
            if typ in ("time", "duration"):
                return lambda v: {"secs": 0, "nsecs": 0} if v is _MISSING else one(v)
            return one
        return lambda v: [] if v is _MISSING else [one(x) for x in v]

"""Every client→server op as a frozen value class whose fields carry their specs, and
validation against them.

Each op is declared once, as a dataclass (``Publish``, ``Subscribe``, ``CallService``, …); its
fields' specs make the table :data:`OPS` that drives the validator here and that the JSON
Schemas in ``protocol/schemas`` are checked against (a test checks the two agree). Type names
are JSON Schema's. :func:`validate_op` returns the op's value, so handlers read attributes
instead of re-reading (and re-checking) dict keys.

Validation is strict where clients are consistent and lenient only where they are not:

* ``integer`` accepts Python ``int`` only: ``100.0`` is a mistyped field, and ``true`` is never
  an integer.
* ``number`` (used for ``auth.t``, ``auth.end`` and ``call_service.timeout``) accepts integers
  and floats, because roslibjs and roslibpy send times as whatever number the user computed.
* ``id`` may be ``null``, meaning "no id" (roslibpy's ``set_status_level`` can send it), except
  where the op requires an id.
* Unknown fields are ignored, as rosbridge does (roslibjs 1.x sends an unused ``type`` with
  ``call_service``, for example).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any, ClassVar, TypeVar

from .errors import LEVELS, MessageId, ProtocolError, message_id

COMPRESSIONS: tuple[str, ...] = ("none", "png", "cbor", "cbor-raw")


@dataclass(frozen=True)
class FieldSpec:
    """One field of an op: its JSON types (empty = any value), and optional enum / minimum."""

    name: str
    types: tuple[str, ...] = ()
    required: bool = False
    enum: tuple[str, ...] = ()
    minimum: int | None = None

    @property
    def valid_types(self) -> frozenset[type] | None:
        """Python types that are valid here with nothing more to check (``None``: any value),
        so the usual field costs one set lookup; anything else gets the full check."""
        if not self.types:
            return None
        if self.enum or self.minimum is not None:
            return frozenset()
        return frozenset(t for name in self.types for t in _PYTHON_TYPES[name])


_PYTHON_TYPES: dict[str, tuple[type, ...]] = {
    "string": (str,),
    "integer": (int,),
    "number": (int, float),
    "boolean": (bool,),
    "object": (dict,),
    "array": (list,),
    "null": (type(None),),
}


@dataclass(frozen=True)
class OpSpec:
    """The fields of one op, in the order they are checked, and the class of its values."""

    op: str
    fields: tuple[FieldSpec, ...]
    cls: type
    keeps_raw: bool = False  # the value also holds the decoded op (``raw``)
    checks: tuple[tuple[FieldSpec, frozenset[type] | None], ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "checks", tuple((f, f.valid_types) for f in self.fields))

    @property
    def required(self) -> tuple[str, ...]:
        """Names of the mandatory fields (``op`` itself excluded)."""
        return tuple(f.name for f in self.fields if f.required)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of all known fields (``op`` itself excluded)."""
        return tuple(f.name for f in self.fields)


_ID = ("string", "integer")
_ARGS = ("object", "array", "null")
_SPEC = "spec"  # the key of a field's FieldSpec in its dataclass metadata


class _Absent:
    """An optional field the client left out, where that differs from sending ``null``."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "ABSENT"


ABSENT: Any = _Absent()


def _req(*types: str, enum: tuple[str, ...] = (), minimum: int | None = None) -> Any:
    """A required field of these JSON types."""
    spec = FieldSpec("", types, required=True, enum=enum, minimum=minimum)
    return field(metadata={_SPEC: spec})


def _opt(
    *types: str, default: Any = None, enum: tuple[str, ...] = (), minimum: int | None = None
) -> Any:
    """An optional field; ``default`` when the client leaves it out."""
    spec = FieldSpec("", types, enum=enum, minimum=minimum)
    return field(default=default, metadata={_SPEC: spec})


def _optional_id() -> Any:
    """The ``id`` most ops have: optional, and ``null`` means none."""
    return _opt(*_ID, "null")


OPS: dict[str, OpSpec] = {}


_Op = TypeVar("_Op", bound=type)


def _register(cls: _Op) -> _Op:
    """Add an op class to :data:`OPS`: its fields' specs, in declaration order."""
    specs = tuple(
        replace(f.metadata[_SPEC], name=f.name) for f in fields(cls) if _SPEC in f.metadata
    )
    OPS[cls.OP] = OpSpec(cls.OP, specs, cls, keeps_raw="raw" in cls.__dataclass_fields__)
    return cls


# One frozen value per op, checked against its fields' specs by validate_op. Declaration order
# is the order fields are checked in and the order of the JSON Schemas' properties.


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Fragment:
    OP: ClassVar[str] = "fragment"
    id: MessageId = _req(*_ID)
    data: str = _req("string")
    num: int = _req("integer", minimum=0)
    total: int = _req("integer", minimum=1)


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Png:
    OP: ClassVar[str] = "png"
    id: MessageId = _optional_id()
    data: str = _req("string")
    num: int | None = _opt("integer", minimum=0)
    total: int | None = _opt("integer", minimum=1)


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class SetLevel:
    OP: ClassVar[str] = "set_level"
    id: MessageId = _optional_id()
    level: str = _req("string", enum=LEVELS)


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Auth:
    """A named token (``token``), or rosauth's MAC with all of its fields; the session
    refuses an op with neither."""

    OP: ClassVar[str] = "auth"
    id: MessageId = _optional_id()
    token: str | None = _opt("string")
    mac: str | None = _opt("string")
    client: str | None = _opt("string")
    dest: str | None = _opt("string")
    rand: str | None = _opt("string")
    t: float | None = _opt("number")
    level: str | None = _opt("string")
    end: float | None = _opt("number")

    MAC_FIELDS: ClassVar[tuple[str, ...]] = ("mac", "client", "dest", "rand", "t", "level",
                                             "end")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Advertise:
    OP: ClassVar[str] = "advertise"
    id: MessageId = _optional_id()
    topic: str = _req("string")
    type: str = _req("string")
    latch: bool = _opt("boolean", default=False)
    queue_size: int | None = _opt("integer", minimum=0)


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Unadvertise:
    OP: ClassVar[str] = "unadvertise"
    id: MessageId = _optional_id()
    topic: str = _req("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Publish:
    """``raw`` is the decoded op itself: its keys, in the client's order, let the client's own
    text be sent on as the outgoing publish (session/rosbridge/verbatim.py)."""

    OP: ClassVar[str] = "publish"
    id: MessageId = _optional_id()
    topic: str = _req("string")
    msg: Any = _opt(default=ABSENT)
    latch: bool = _opt("boolean", default=False)
    queue_size: int | None = _opt("integer", minimum=0)
    raw: dict = field(default_factory=dict, repr=False, compare=False)


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Subscribe:
    OP: ClassVar[str] = "subscribe"
    id: MessageId = _optional_id()
    topic: str = _req("string")
    type: str | None = _opt("string")
    throttle_rate: int = _opt("integer", default=0, minimum=0)
    queue_length: int = _opt("integer", default=0, minimum=0)
    fragment_size: int | None = _opt("integer", minimum=1)
    compression: str = _opt("string", default="none", enum=COMPRESSIONS)


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class Unsubscribe:
    OP: ClassVar[str] = "unsubscribe"
    id: MessageId = _optional_id()
    topic: str = _req("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class CallService:
    """``compression`` is any string here: an unknown one is answered by a failed
    ``service_response`` (session/rosbridge/services.py), not by a status alone."""

    OP: ClassVar[str] = "call_service"
    id: MessageId = _optional_id()
    service: str = _req("string")
    args: dict | list | None = _opt(*_ARGS)
    fragment_size: int | None = _opt("integer", "null", minimum=1)
    compression: str | None = _opt("string")
    timeout: float | None = _opt("number", "null")
    type: str | None = _opt("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class AdvertiseService:
    OP: ClassVar[str] = "advertise_service"
    id: MessageId = _optional_id()
    service: str = _req("string")
    type: str = _req("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class UnadvertiseService:
    OP: ClassVar[str] = "unadvertise_service"
    id: MessageId = _optional_id()
    service: str = _req("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class ServiceResponse:
    OP: ClassVar[str] = "service_response"
    service: str = _req("string")
    id: MessageId = _req(*_ID)
    result: bool = _req("boolean")
    values: Any = _opt()


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class AdvertiseAction:
    OP: ClassVar[str] = "advertise_action"
    id: MessageId = _optional_id()
    action: str = _req("string")
    type: str = _req("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class UnadvertiseAction:
    OP: ClassVar[str] = "unadvertise_action"
    id: MessageId = _optional_id()
    action: str = _req("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class SendActionGoal:
    OP: ClassVar[str] = "send_action_goal"
    id: MessageId = _optional_id()
    action: str = _req("string")
    action_type: str = _req("string")
    args: dict | list | None = _opt(*_ARGS)
    feedback: bool = _opt("boolean", default=False)
    cancel_on_disconnect: bool = _opt("boolean", default=False)
    fragment_size: int | None = _opt("integer", "null", minimum=1)
    compression: str | None = _opt("string")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class CancelActionGoal:
    OP: ClassVar[str] = "cancel_action_goal"
    action: str = _req("string")
    id: MessageId = _req(*_ID)


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class ActionFeedback:
    OP: ClassVar[str] = "action_feedback"
    action: str = _req("string")
    id: MessageId = _req(*_ID)
    values: dict = _req("object")


@_register
@dataclass(frozen=True, slots=True, kw_only=True)
class ActionResult:
    OP: ClassVar[str] = "action_result"
    action: str = _req("string")
    id: MessageId = _req(*_ID)
    values: Any = _opt()
    status: int = _req("integer")
    result: bool = _req("boolean")


Op = (
    Fragment | Png | SetLevel | Auth | Advertise | Unadvertise | Publish | Subscribe
    | Unsubscribe | CallService | AdvertiseService | UnadvertiseService | ServiceResponse
    | AdvertiseAction | UnadvertiseAction | SendActionGoal | CancelActionGoal | ActionFeedback
    | ActionResult
)
"""Any validated client→server op."""


def json_type(value: object) -> str:
    """The JSON Schema type name of a decoded value (``integer`` for ints, ``number`` for
    floats), ``bytes`` for CBOR's byte strings, else the Python type name. Op validation and
    the conformance matcher's ``$type`` both name types with it."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, dict):
        return "object"
    if isinstance(value, list):
        return "array"
    if isinstance(value, bytes | bytearray):
        return "bytes"
    return type(value).__name__


def _matches(value: object, types: tuple[str, ...]) -> bool:
    if not types:
        return True
    kind = json_type(value)
    return kind in types or (kind == "integer" and "number" in types)


_ARTICLE = {
    "string": "a string",
    "integer": "an integer",
    "number": "a number",
    "boolean": "a boolean",
    "object": "an object",
    "array": "an array",
    "null": "null",
}


def _expected(types: tuple[str, ...]) -> str:
    words = [_ARTICLE[t] for t in types]
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def _got(value: object) -> str:
    """How a wrong value is described: its JSON type, plus the value itself for a number
    (so ``100.0`` where an integer is expected is visibly the problem)."""
    kind = json_type(value)
    return f"number {value!r}" if kind == "number" else kind


def _check_field(op: str, spec: FieldSpec, value: object) -> str | None:
    """The error text for one present field, or ``None`` when it is valid."""
    where = f"{op}: field '{spec.name}'"
    if not _matches(value, spec.types):
        return f"{where} must be {_expected(spec.types)}, got {_got(value)}"
    if spec.enum and value not in spec.enum:
        choices = ", ".join(f"'{choice}'" for choice in spec.enum)
        return f"{where} must be one of {choices}, got {value!r}"
    if (
        spec.minimum is not None
        and isinstance(value, int | float)
        and not isinstance(value, bool)
        and value < spec.minimum
    ):
        return f"{where} must be {spec.minimum} or greater, got {value!r}"
    return None


def parse_message(obj: object) -> dict:
    """Check that a decoded JSON value is a protocol message: an object with a string ``op``.

    Raises :class:`ProtocolError` naming ``op``, tagged with the message's id when it has a
    valid one.
    """
    if not isinstance(obj, dict):
        raise ProtocolError(
            f"a message must be a JSON object with a string field 'op', got {json_type(obj)}"
        )
    if "op" not in obj:
        raise ProtocolError("message has no field 'op' (the operation name)", message_id(obj))
    if not isinstance(obj["op"], str):
        raise ProtocolError(f"field 'op' must be a string, got {_got(obj['op'])}", message_id(obj))
    return obj


def validate_op(msg: dict) -> Op:
    """Check a parsed message against the spec of its op and return its typed, frozen value.

    Checks that the op is known, that required fields are present and that every known field
    has the right type, enum value and range. The first problem raises :class:`ProtocolError`
    naming the op and the field, tagged with the message's id when valid. Unknown fields are
    left out of the value; fields the client left out get their defaults.
    """
    op = msg["op"]
    spec = OPS.get(op)
    if spec is None:
        raise ProtocolError(f"unknown op '{op}'", message_id(msg))
    values: dict[str, Any] = {}
    for field_spec, valid_types in spec.checks:
        name = field_spec.name
        if name not in msg:
            if field_spec.required:
                raise ProtocolError(f"{op}: missing required field '{name}'", message_id(msg))
            continue
        value = values[name] = msg[name]
        if valid_types is None or type(value) in valid_types:
            continue
        problem = _check_field(op, field_spec, value)
        if problem is not None:
            raise ProtocolError(problem, message_id(msg))
    if spec.keeps_raw:
        values["raw"] = msg
    return spec.cls(**values)


# ---------------------------------------------------------------------- server → client
# What the server sends besides a topic's ``publish`` (the wire floor's: its body encoded once
# for every subscriber) and ``status`` (:func:`.errors.status_op`): the answers to a client's
# calls and goals, and the requests it is handed as a provider. An ``id`` is left out when
# the request had none, as the spec's optional field says.


def _with_id(op: dict, id: MessageId) -> dict:
    if id is not None:
        op["id"] = id
    return op


def service_response(service: str, id: MessageId, values: Any, result: bool) -> dict:
    """The answer to a ``call_service`` (``values``: the response, or why it failed)."""
    op = _with_id({"op": "service_response", "service": service}, id)
    op["values"] = values
    op["result"] = result
    return op


def action_result(action: str, id: MessageId, values: Any, status: int, result: bool) -> dict:
    """The end of a goal sent with ``send_action_goal``."""
    op = _with_id({"op": "action_result", "action": action}, id)
    op["values"] = values
    op["status"] = status
    op["result"] = result
    return op


def action_feedback(action: str, id: MessageId, values: Any) -> dict:
    """A running goal's feedback."""
    op = _with_id({"op": "action_feedback", "action": action}, id)
    op["values"] = values
    return op


def call_service(id: str, service: str, args: Any) -> dict:
    """A call handed to the client that provides ``service``."""
    return {"op": "call_service", "id": id, "service": service, "args": args}


def send_action_goal(id: str, action: str, action_type: str, args: Any) -> dict:
    """A goal handed to the client that provides ``action`` (its feedback is asked for)."""
    return {"op": "send_action_goal", "id": id, "action": action, "action_type": action_type,
            "args": args, "feedback": True}


def cancel_action_goal(id: str, action: str) -> dict:
    """A goal handed to a providing client was cancelled."""
    return {"op": "cancel_action_goal", "id": id, "action": action}

"""Declarative field specs of every client→server op, and validation against them.

The specs are data so that one table drives both the validator here and the JSON Schemas in
``protocol/schemas`` (a test checks the two agree). Type names are JSON Schema's.

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

from dataclasses import dataclass

from .errors import ProtocolError, message_id
from .status import LEVELS

COMPRESSIONS: tuple[str, ...] = ("none", "png", "cbor", "cbor-raw")


@dataclass(frozen=True)
class FieldSpec:
    """One field of an op: its JSON types (empty = any value), and optional enum / minimum."""

    name: str
    types: tuple[str, ...] = ()
    required: bool = False
    enum: tuple[str, ...] = ()
    minimum: int | None = None


@dataclass(frozen=True)
class OpSpec:
    """The fields of one op, in the order they are checked."""

    op: str
    fields: tuple[FieldSpec, ...]

    @property
    def required(self) -> tuple[str, ...]:
        """Names of the mandatory fields (``op`` itself excluded)."""
        return tuple(f.name for f in self.fields if f.required)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of all known fields (``op`` itself excluded)."""
        return tuple(f.name for f in self.fields)


_ID = ("string", "integer")
_OPTIONAL_ID = FieldSpec("id", (*_ID, "null"))


def _req(name: str, *types: str, minimum: int | None = None) -> FieldSpec:
    return FieldSpec(name, types, required=True, minimum=minimum)


def _opt(
    name: str, *types: str, enum: tuple[str, ...] = (), minimum: int | None = None
) -> FieldSpec:
    return FieldSpec(name, types, enum=enum, minimum=minimum)


def _spec(op: str, *fields: FieldSpec) -> OpSpec:
    """An op spec; every op has an optional ``id`` unless it declares ``id`` itself."""
    if not any(f.name == "id" for f in fields):
        fields = (_OPTIONAL_ID, *fields)
    return OpSpec(op, fields)


_ARGS = ("object", "array", "null")

OPS: dict[str, OpSpec] = {
    spec.op: spec
    for spec in (
        _spec(
            "fragment",
            _req("id", *_ID),
            _req("data", "string"),
            _req("num", "integer", minimum=0),
            _req("total", "integer", minimum=1),
        ),
        _spec(
            "png",
            _req("data", "string"),
            _opt("num", "integer", minimum=0),
            _opt("total", "integer", minimum=1),
        ),
        _spec("set_level", FieldSpec("level", ("string",), required=True, enum=LEVELS)),
        _spec(
            "auth",
            _req("mac", "string"),
            _req("client", "string"),
            _req("dest", "string"),
            _req("rand", "string"),
            _req("t", "number"),
            _req("level", "string"),
            _req("end", "number"),
        ),
        _spec(
            "advertise",
            _req("topic", "string"),
            _req("type", "string"),
            _opt("latch", "boolean"),
            _opt("queue_size", "integer", minimum=0),
        ),
        _spec("unadvertise", _req("topic", "string")),
        _spec(
            "publish",
            _req("topic", "string"),
            _opt("msg"),
            _opt("latch", "boolean"),
            _opt("queue_size", "integer", minimum=0),
        ),
        _spec(
            "subscribe",
            _req("topic", "string"),
            _opt("type", "string"),
            _opt("throttle_rate", "integer", minimum=0),
            _opt("queue_length", "integer", minimum=0),
            _opt("fragment_size", "integer", minimum=1),
            _opt("compression", "string", enum=COMPRESSIONS),
        ),
        _spec("unsubscribe", _req("topic", "string")),
        _spec(
            "call_service",
            _req("service", "string"),
            _opt("args", *_ARGS),
            _opt("fragment_size", "integer", "null", minimum=1),
            _opt("compression", "string"),
            _opt("timeout", "number", "null"),
            _opt("type", "string"),
        ),
        _spec("advertise_service", _req("service", "string"), _req("type", "string")),
        _spec("unadvertise_service", _req("service", "string")),
        _spec(
            "service_response",
            _req("service", "string"),
            _req("id", *_ID),
            _req("result", "boolean"),
            _opt("values"),
        ),
        _spec("advertise_action", _req("action", "string"), _req("type", "string")),
        _spec("unadvertise_action", _req("action", "string")),
        _spec(
            "send_action_goal",
            _req("action", "string"),
            _req("action_type", "string"),
            _opt("args", *_ARGS),
            _opt("feedback", "boolean"),
            _opt("fragment_size", "integer", "null", minimum=1),
            _opt("compression", "string"),
        ),
        _spec("cancel_action_goal", _req("action", "string"), _req("id", *_ID)),
        _spec(
            "action_feedback",
            _req("action", "string"),
            _req("id", *_ID),
            _req("values", "object"),
        ),
        _spec(
            "action_result",
            _req("action", "string"),
            _req("id", *_ID),
            _opt("values"),
            _req("status", "integer"),
            _req("result", "boolean"),
        ),
    )
}


def json_type(value: object) -> str:
    """The JSON Schema type name of a decoded JSON value (``integer`` for ints, ``number`` for
    floats); the Python type name for anything JSON cannot produce."""
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


def validate_op(msg: dict) -> dict:
    """Check a parsed message against the spec of its op and return it unchanged.

    Checks that the op is known, that required fields are present and that every known field
    has the right type, enum value and range. The first problem raises :class:`ProtocolError`
    naming the op and the field, tagged with the message's id when valid.
    """
    op = msg["op"]
    spec = OPS.get(op)
    if spec is None:
        raise ProtocolError(f"unknown op '{op}'", message_id(msg))
    for field in spec.fields:
        if field.name not in msg:
            if field.required:
                raise ProtocolError(f"{op}: missing required field '{field.name}'", message_id(msg))
            continue
        problem = _check_field(op, field, msg[field.name])
        if problem is not None:
            raise ProtocolError(problem, message_id(msg))
    return msg

"""The Foxglove WebSocket protocol (``foxglove.websocket.v1``, ``foxglove.sdk.v1``), sans-I/O.

Parses what a Foxglove or Lichtblick client sends (JSON ops and binary frames) into checked,
frozen values (one class per op, as rosbridge's ``protocol/ops.py``: :func:`parse_op`), and
builds what the server sends. Nothing here touches a socket or the bus; the
Foxglove session (session/foxglove/) drives it. Every malformed input raises
:class:`FoxgloveError` whose text names the op and the field, never anything else.

``foxglove.sdk.v1`` differs where this server is concerned only in ``subscribe``: a
subscription's ``id`` may be left out (the server picks one and answers with
``subscriptionResponse``, the ids in the order asked).
"""

from __future__ import annotations

import base64
import math
import re
import struct
from dataclasses import dataclass
from typing import Any, ClassVar

import orjson

from ..types import jsoncodec

SUBPROTOCOL_V1 = "foxglove.websocket.v1"
SUBPROTOCOL_SDK = "foxglove.sdk.v1"
SUBPROTOCOLS = (SUBPROTOCOL_V1, SUBPROTOCOL_SDK)

CAPABILITIES = (
    "clientPublish",
    "services",
    "parameters",
    "parametersSubscribe",
    "connectionGraph",
    "time",
)
ENCODING = "cdr"
SCHEMA_ENCODING = "ros2msg"

# Status levels (the spec's numbers).
INFO, WARNING, ERROR = 0, 1, 2

# Binary opcodes.
SERVER_MESSAGE_DATA, SERVER_TIME, SERVER_SERVICE_CALL_RESPONSE = 1, 2, 3
CLIENT_MESSAGE_DATA, CLIENT_SERVICE_CALL_REQUEST = 1, 2

MAX_ITEMS = 10_000
"""Most entries one op may list (subscriptions, channels, parameter names)."""
MAX_ENCODING = 64
"""Longest encoding name a service call request may carry."""
U32 = 0xFFFFFFFF

_MSG_HEADER = struct.Struct("<BIQ")
_TIME = struct.Struct("<BQ")
_CALL_HEADER = struct.Struct("<BIII")
_CHANNEL = struct.Struct("<BI")


class FoxgloveError(Exception):
    """A client frame that breaks the protocol; the text names the op and the field."""


# ---------------------------------------------------------------------- client → server
@dataclass(frozen=True, slots=True)
class ClientChannel:
    id: int
    topic: str
    encoding: str
    schema_name: str


@dataclass(frozen=True, slots=True)
class ClientMessage:
    """Binary op 1: a message on a channel the client advertised."""

    channel_id: int
    payload: bytes


@dataclass(frozen=True, slots=True)
class ServiceCallRequest:
    """Binary op 2."""

    service_id: int
    call_id: int
    encoding: str
    payload: bytes


@dataclass(frozen=True, slots=True)
class Subscribe:
    LISTS: ClassVar[str | None] = "subscriptions"  # the field a long op is handled in steps of
    subscriptions: tuple[tuple[int | None, int], ...]  # (id, or None: the server picks; channel)


@dataclass(frozen=True, slots=True)
class Unsubscribe:
    LISTS: ClassVar[str | None] = "subscription_ids"
    subscription_ids: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class Advertise:
    LISTS: ClassVar[str | None] = "channels"
    channels: tuple[ClientChannel, ...]


@dataclass(frozen=True, slots=True)
class Unadvertise:
    LISTS: ClassVar[str | None] = "channel_ids"
    channel_ids: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class GetParameters:
    LISTS: ClassVar[str | None] = None
    parameter_names: tuple[str, ...]
    id: str | None = None


@dataclass(frozen=True, slots=True)
class SetParameters:
    LISTS: ClassVar[str | None] = None
    parameters: tuple[tuple[str, Any], ...]  # (name, value: None unsets it)
    id: str | None = None


@dataclass(frozen=True, slots=True)
class SubscribeParameterUpdates:
    LISTS: ClassVar[str | None] = None
    parameter_names: tuple[str, ...]
    id: str | None = None


@dataclass(frozen=True, slots=True)
class UnsubscribeParameterUpdates:
    LISTS: ClassVar[str | None] = None
    parameter_names: tuple[str, ...]
    id: str | None = None


@dataclass(frozen=True, slots=True)
class SubscribeConnectionGraph:
    LISTS: ClassVar[str | None] = None


@dataclass(frozen=True, slots=True)
class UnsubscribeConnectionGraph:
    LISTS: ClassVar[str | None] = None


@dataclass(frozen=True, slots=True)
class FetchAsset:
    LISTS: ClassVar[str | None] = None
    request_id: int
    uri: str


ClientOp = (Subscribe | Unsubscribe | Advertise | Unadvertise | GetParameters | SetParameters
            | SubscribeParameterUpdates | UnsubscribeParameterUpdates | SubscribeConnectionGraph
            | UnsubscribeConnectionGraph | FetchAsset)


def _u32(value: Any, op: str, field: str) -> int:
    if value.__class__ is int and 0 <= value <= U32:  # the common case, checked fast
        return value
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= U32:
        raise FoxgloveError(f"{op}: field '{field}' must be an integer 0..{U32}, not {value!r:.60}")
    return value


def _str(value: Any, op: str, field: str, *, empty: bool = False) -> str:
    if not isinstance(value, str) or (not empty and not value):
        raise FoxgloveError(f"{op}: field '{field}' must be a non-empty string")
    return value


def _list(obj: dict, op: str, field: str) -> list:
    value = obj.get(field)
    if not isinstance(value, list):
        raise FoxgloveError(f"{op}: field '{field}' must be a list")
    if len(value) > MAX_ITEMS:
        raise FoxgloveError(f"{op}: field '{field}' lists {len(value)} items (at most {MAX_ITEMS})")
    return value


def _dict(value: Any, op: str, field: str) -> dict:
    if not isinstance(value, dict):
        raise FoxgloveError(f"{op}: each entry of '{field}' must be an object")
    return value


def _request_id(obj: dict, op: str) -> str | None:
    value = obj.get("id")
    if value is not None and not isinstance(value, str):
        raise FoxgloveError(f"{op}: field 'id' must be a string")
    return value


def parse_op(data: str | bytes) -> ClientOp:
    """A JSON op as its frozen value, every field checked (:class:`FoxgloveError` otherwise)."""
    return client_op(parse_text(data))


def client_op(fields: dict) -> ClientOp:
    """The frozen op of :func:`parse_text`'s checked fields (lists become tuples)."""
    cls = OPS[fields["op"]]
    return cls(**{_FIELDS[name]: tuple(value) if value.__class__ is list else value
                  for name, value in fields.items() if name != "op"})


def parse_text(data: str | bytes) -> dict:
    """A JSON op as a dict with its fields checked (``op`` and the fields its handler reads),
    by their wire names (:func:`client_op` makes its frozen value).

    Subscriptions come back as ``(id or None, channelId)`` pairs, client channels as
    :class:`ClientChannel`, parameters as ``(name, value)`` pairs (wire types decoded).
    """
    try:
        obj = orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        raise FoxgloveError(f"invalid JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise FoxgloveError("invalid op: a text frame must be a JSON object")
    op = obj.get("op")
    if not isinstance(op, str):
        raise FoxgloveError("invalid op: field 'op' must be a string")
    parse = _PARSERS.get(op)
    if parse is None:
        raise FoxgloveError(f"unknown op {op!r:.60}")
    out = parse(obj)
    out["op"] = op
    return out


def _u32s(values: list) -> bool:
    """Whether every value is an integer 0..2**32-1, checked in C (no Python loop): an op may
    list 10,000 of them."""
    return not values or (set(map(type, values)) == {int} and min(values) >= 0
                          and max(values) <= U32)


def _parse_subscribe(obj: dict) -> dict:
    entries = _list(obj, "subscribe", "subscriptions")
    if set(map(type, entries)) <= {dict}:  # the fast path; the loop below names what is wrong
        ids = [entry.get("id") for entry in entries]
        channels = [entry.get("channelId") for entry in entries]
        if _u32s(channels) and (_u32s(ids) or _u32s([i for i in ids if i is not None])):
            return {"subscriptions": list(zip(ids, channels, strict=True))}
    subs = []
    append = subs.append
    for entry in entries:
        if entry.__class__ is not dict:
            _dict(entry, "subscribe", "subscriptions")
        sub_id = entry.get("id")
        append((None if sub_id is None else _u32(sub_id, "subscribe", "subscriptions[].id"),
                _u32(entry.get("channelId"), "subscribe", "subscriptions[].channelId")))
    return {"subscriptions": subs}


def _parse_ids(field: str):
    def parse(obj: dict) -> dict:
        op = obj["op"]
        values = _list(obj, op, field)
        return {field: values if _u32s(values) else [_u32(v, op, field) for v in values]}

    return parse


def _parse_advertise(obj: dict) -> dict:
    channels = []
    for entry in _list(obj, "advertise", "channels"):
        entry = _dict(entry, "advertise", "channels")
        channels.append(
            ClientChannel(
                _u32(entry.get("id"), "advertise", "channels[].id"),
                _str(entry.get("topic"), "advertise", "channels[].topic"),
                _str(entry.get("encoding"), "advertise", "channels[].encoding"),
                _str(entry.get("schemaName"), "advertise", "channels[].schemaName"),
            )
        )
    return {"channels": channels}


def _parse_names(obj: dict) -> dict:
    op = obj["op"]
    names = [_str(v, op, "parameterNames") for v in _list(obj, op, "parameterNames")]
    return {"parameterNames": names, "id": _request_id(obj, op)}


def _parse_set_parameters(obj: dict) -> dict:
    params = []
    for entry in _list(obj, "setParameters", "parameters"):
        entry = _dict(entry, "setParameters", "parameters")
        name = _str(entry.get("name"), "setParameters", "parameters[].name")
        params.append((name, param_from_wire(entry)))
    return {"parameters": params, "id": _request_id(obj, "setParameters")}


def _parse_empty(obj: dict) -> dict:
    return {}


def _parse_fetch_asset(obj: dict) -> dict:
    return {"requestId": _u32(obj.get("requestId"), "fetchAsset", "requestId"),
            "uri": _str(obj.get("uri"), "fetchAsset", "uri")}


_PARSERS = {
    "subscribe": _parse_subscribe,
    "unsubscribe": _parse_ids("subscriptionIds"),
    "advertise": _parse_advertise,
    "unadvertise": _parse_ids("channelIds"),
    "getParameters": _parse_names,
    "setParameters": _parse_set_parameters,
    "subscribeParameterUpdates": _parse_names,
    "unsubscribeParameterUpdates": _parse_names,
    "subscribeConnectionGraph": _parse_empty,
    "unsubscribeConnectionGraph": _parse_empty,
    "fetchAsset": _parse_fetch_asset,
}
CLIENT_OPS = tuple(_PARSERS)
OPS: dict[str, type[ClientOp]] = {
    "subscribe": Subscribe,
    "unsubscribe": Unsubscribe,
    "advertise": Advertise,
    "unadvertise": Unadvertise,
    "getParameters": GetParameters,
    "setParameters": SetParameters,
    "subscribeParameterUpdates": SubscribeParameterUpdates,
    "unsubscribeParameterUpdates": UnsubscribeParameterUpdates,
    "subscribeConnectionGraph": SubscribeConnectionGraph,
    "unsubscribeConnectionGraph": UnsubscribeConnectionGraph,
    "fetchAsset": FetchAsset,
}
"""Each JSON op's frozen class, by its ``op``."""
_FIELDS = {"subscriptions": "subscriptions", "subscriptionIds": "subscription_ids",
           "channels": "channels", "channelIds": "channel_ids",
           "parameterNames": "parameter_names", "parameters": "parameters", "id": "id",
           "requestId": "request_id", "uri": "uri"}
"""A checked field's wire name → its name in the op's class."""


def parse_binary(data: bytes) -> ClientMessage | ServiceCallRequest:
    """A binary client frame: message data (op 1) or a service call request (op 2)."""
    if not data:
        raise FoxgloveError("binary frame: empty")
    opcode = data[0]
    if opcode == CLIENT_MESSAGE_DATA:
        if len(data) < _CHANNEL.size:
            raise FoxgloveError(f"message data: {len(data)} bytes, shorter than its header (5)")
        _, channel_id = _CHANNEL.unpack_from(data)
        return ClientMessage(channel_id, bytes(data[_CHANNEL.size :]))
    if opcode == CLIENT_SERVICE_CALL_REQUEST:
        if len(data) < _CALL_HEADER.size:
            raise FoxgloveError(
                f"service call request: {len(data)} bytes, shorter than its header (13)"
            )
        _, service_id, call_id, length = _CALL_HEADER.unpack_from(data)
        start = _CALL_HEADER.size
        if length > MAX_ENCODING or start + length > len(data):
            raise FoxgloveError(
                f"service call request: field 'encoding length' {length} exceeds the frame or "
                f"{MAX_ENCODING} bytes"
            )
        try:
            encoding = bytes(data[start : start + length]).decode("utf-8")
        except UnicodeDecodeError:
            raise FoxgloveError("service call request: field 'encoding' is not UTF-8") from None
        return ServiceCallRequest(service_id, call_id, encoding, bytes(data[start + length :]))
    raise FoxgloveError(f"binary frame: unknown opcode {opcode}")


# ---------------------------------------------------------------------- parameters
def param_to_wire(name: str, value: Any) -> dict:
    """A parameter as the protocol carries it (``type`` marks bytes and floats)."""
    if isinstance(value, bytes | bytearray):
        return {"name": name, "value": base64.b64encode(value).decode("ascii"),
                "type": "byte_array"}
    if isinstance(value, float):
        return {"name": name, "value": value, "type": "float64"}
    if isinstance(value, list) and value and all(isinstance(v, float) for v in value):
        return {"name": name, "value": value, "type": "float64_array"}
    return {"name": name, "value": value}


def param_from_wire(entry: dict) -> Any:
    """The value of a wire parameter (``None``: unset it); checks ``type`` against ``value``."""
    value, kind = entry.get("value"), entry.get("type")
    if kind is None:
        _check_value(value)
        return value
    if kind == "byte_array":
        if not isinstance(value, str):
            raise FoxgloveError("setParameters: a 'byte_array' value must be a base64 string")
        try:
            # the bus's parameters are JSON (rosapi serves them): the bytes as a list of ints
            return list(base64.b64decode(value, validate=True))
        except ValueError:
            raise FoxgloveError("setParameters: field 'value' is not valid base64") from None
    if kind == "float64":
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise FoxgloveError("setParameters: a 'float64' value must be a number")
        return float(value)
    if kind == "float64_array":
        if not isinstance(value, list) or any(
            isinstance(v, bool) or not isinstance(v, int | float) for v in value
        ):
            raise FoxgloveError("setParameters: a 'float64_array' value must be a list of numbers")
        return [float(v) for v in value]
    raise FoxgloveError(f"setParameters: field 'type' {kind!r:.40} is not a parameter type")


def _check_value(value: Any, depth: int = 0) -> None:
    if depth > 32:
        raise FoxgloveError("setParameters: field 'value' is nested too deep")
    if isinstance(value, float) and not math.isfinite(value):
        raise FoxgloveError("setParameters: field 'value' is not a finite number")
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 2**63:
        raise FoxgloveError("setParameters: field 'value' is out of the 64-bit range")
    if isinstance(value, list):
        for v in value:
            _check_value(v, depth + 1)
    elif isinstance(value, dict):
        for v in value.values():
            _check_value(v, depth + 1)


# ---------------------------------------------------------------------- server → client
def dumps(obj: dict) -> bytes:
    """A JSON op as snug bytes (``jsoncodec.dumps``: orjson's own output keeps ~4 KiB more
    than its text, so 160,000 queued ``serviceCallFailure`` ops held 640 MB, not 16)."""
    return jsoncodec.dumps(obj)


def server_info(name: str, session_id: str, metadata: dict[str, str]) -> dict:
    return {
        "op": "serverInfo",
        "name": name,
        "capabilities": list(CAPABILITIES),
        "supportedEncodings": [ENCODING],
        "metadata": metadata,
        "sessionId": session_id,
    }


def status(level: int, message: str, status_id: str | None = None) -> dict:
    out: dict = {"op": "status", "level": level, "message": message}
    if status_id is not None:
        out["id"] = status_id
    return out


_ROS2_FIELD = re.compile(r"[a-z][a-z0-9_]*")
_CAMEL = re.compile(r"(?<=[a-z0-9])(?=[A-Z])")


def ros2_schema(definition: str) -> str:
    """A definition as ROS 2's parser (Foxglove's ``ros2msg``) accepts it: field names with
    upper-case letters (``maskAction`` of map_messages, a ROS 1 package) become snake_case.
    CDR is positional, so the bytes on the wire do not change."""
    lines = definition.split("\n")
    for i, line in enumerate(lines):
        parts = line.split(maxsplit=2)
        if len(parts) < 2 or parts[0] == "MSG:" or "=" in parts[1]:
            continue
        name = parts[1]
        if not _ROS2_FIELD.fullmatch(name):
            lines[i] = " ".join([parts[0], _CAMEL.sub("_", name).lower(), *parts[2:]])
    return "\n".join(lines)


def channel(channel_id: int, topic: str, schema_name: str, schema: str) -> dict:
    return {
        "id": channel_id,
        "topic": topic,
        "encoding": ENCODING,
        "schemaName": schema_name,
        "schema": ros2_schema(schema),
        "schemaEncoding": SCHEMA_ENCODING,
    }


def advertise(channels: list[dict]) -> dict:
    return {"op": "advertise", "channels": channels}


def unadvertise(channel_ids: list[int]) -> dict:
    return {"op": "unadvertise", "channelIds": channel_ids}


def service(
    service_id: int, name: str, type_name: str, request: tuple[str, str],
    response: tuple[str, str],
) -> dict:
    """A service for ``advertiseServices``; ``request``/``response`` are (schema name, text).
    Both the current ``request``/``response`` objects and the older ``requestSchema``/
    ``responseSchema`` strings are given, so old and new clients read it."""

    def part(schema: tuple[str, str]) -> dict:
        return {"encoding": ENCODING, "schemaName": schema[0],
                "schemaEncoding": SCHEMA_ENCODING, "schema": ros2_schema(schema[1])}

    return {
        "id": service_id,
        "name": name,
        "type": type_name,
        "request": part(request),
        "response": part(response),
        "requestSchema": ros2_schema(request[1]),
        "responseSchema": ros2_schema(response[1]),
    }


def advertise_services(services: list[dict]) -> dict:
    return {"op": "advertiseServices", "services": services}


def unadvertise_services(service_ids: list[int]) -> dict:
    return {"op": "unadvertiseServices", "serviceIds": service_ids}


def parameter_values(parameters: list[dict], request_id: str | None = None) -> dict:
    out: dict = {"op": "parameterValues", "parameters": parameters}
    if request_id is not None:
        out["id"] = request_id
    return out


def service_call_failure(service_id: int, call_id: int, message: str) -> dict:
    return {"op": "serviceCallFailure", "serviceId": service_id, "callId": call_id,
            "message": message}


def subscription_response(subscriptions: list[tuple[int, int]]) -> dict:
    """``foxglove.sdk.v1``: the ids the server gave the subscriptions, in the order asked."""
    return {"op": "subscriptionResponse",
            "subscriptions": [{"id": i, "channelId": c} for i, c in subscriptions]}


def connection_graph_update(
    published: dict[str, list[str]],
    subscribed: dict[str, list[str]],
    services: dict[str, list[str]],
    removed_topics: list[str],
    removed_services: list[str],
) -> dict:
    return {
        "op": "connectionGraphUpdate",
        "publishedTopics": [{"name": n, "publisherIds": ids} for n, ids in published.items()],
        "subscribedTopics": [{"name": n, "subscriberIds": ids} for n, ids in subscribed.items()],
        "advertisedServices": [{"name": n, "providerIds": ids} for n, ids in services.items()],
        "removedTopics": removed_topics,
        "removedServices": removed_services,
    }


def message_data(subscription_id: int, timestamp_ns: int, payload: bytes) -> bytes:
    """Binary op 1: one message for one subscription (``payload`` is shared CDR bytes)."""
    return _MSG_HEADER.pack(SERVER_MESSAGE_DATA, subscription_id, timestamp_ns) + payload


def time(timestamp_ns: int) -> bytes:
    """Binary op 2: the server's clock."""
    return _TIME.pack(SERVER_TIME, timestamp_ns)


def service_call_response(service_id: int, call_id: int, encoding: str, payload: bytes) -> bytes:
    """Binary op 3."""
    enc = encoding.encode("utf-8")
    return _CALL_HEADER.pack(SERVER_SERVICE_CALL_RESPONSE, service_id, call_id, len(enc)) + (
        enc + payload
    )


def nanoseconds(seconds: float) -> int:
    """A bus stamp (UNIX seconds) as the protocol's uint64 nanoseconds."""
    return max(0, min(round(seconds * 1e9), 2**64 - 1))

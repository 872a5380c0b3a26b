"""Replay the protocol conformance vectors against a running server.

Usage::

    hitrobot-server conformance --url ws://127.0.0.1:9090
    python -m hitrobot_server.conformance.runner --url ws://127.0.0.1:9090 \\
        [--vectors DIR_OR_FILE] [--only TEXT ...] [--timeout-scale FACTOR]

The runner speaks only the wire protocol and imports nothing from the server, so it can check
any rosbridge-v2 ("hitrobot protocol") server. It prints one table row per case
(``name | result | detail``), then a summary line ``N passed, M failed``. The exit code is 0
when every case passed, 1 when one failed and 2 when the vectors could not be loaded.

Vector files (``protocol/vectors/*.json``) are JSON objects ``{"description": ..., "cases":
[...]}``. A case is ``{"name": ..., "clients": ["a", "b"], "steps": [...]}``; every client is
its own WebSocket connection, opened before the first step and closed after the last. Steps
run in order; each is one of:

``{"client": "a", "send": {...}}``
    send the op as a JSON text frame.
``{"client": "a", "send_raw": "text"}``
    send the text as is (for malformed JSON).
``{"client": "a", "send_fragmented": {...}, "fragment_size": N, "reverse": false}``
    send the op's JSON as ``fragment`` ops of N characters each (in reverse order if asked).
``{"client": "a", "expect": PATTERN, "within_ms": 2000}``
    wait for a JSON text frame matching the pattern.
``{"client": "a", "expect_none": PATTERN, "within_ms": 300}``
    fail if a JSON text frame matching the pattern is received (or already waiting) within
    the window.
``{"client": "a", "expect_png": PATTERN}``
    wait for a ``png`` op whose decoded op matches (the PNG must be 8-bit RGB of the exact
    size the protocol prescribes, and its text ASCII JSON).
``{"client": "a", "expect_cbor": PATTERN}``
    wait for a binary frame whose CBOR, with RFC 8746 typed arrays decoded to lists, matches.
``{"client": "a", "expect_fragments": PATTERN, "max_data_len": N}``
    wait for a complete set of ``fragment`` ops whose joined ``data`` is JSON matching the
    pattern; every fragment must have a non-empty string ``id``, integer ``num`` and ``total``
    and string ``data``, and ``max_data_len`` bounds the length of each ``data``.
``{"close": "a"}``
    close that client's connection.
``{"sleep_ms": N}``
    wait.

Any step may carry a ``note`` string. Waits default to 2000 ms (300 ms for ``expect_none``).

Expect steps look at everything the client has received and not yet consumed, oldest first;
the first frame that matches is consumed and every other frame is left for later steps, so
unrelated traffic (a ``status`` nobody asked about, another subscription's data) is skipped
rather than failed on. A step that times out fails the case. So does a connection the server
closes, because the protocol keeps connections open after errors.

Patterns are described in :mod:`hitrobot_server.conformance.matcher`. Strings in sends and
patterns may contain placeholders: ``${ns}`` is a namespace unique to the case run (such as
``/conf_1a2b3c4d``), ``${ns_rel}`` the same without the leading slash, and ``${NAME}`` a value
an earlier step captured with ``{"$capture": "NAME"}``. A string that is a single placeholder
takes the captured value with its type (an integer id stays an integer).
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import contextlib
import io
import json
import math
import re
import secrets
import struct
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cbor2
from PIL import Image
from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed, WebSocketException

from .matcher import PatternError, check_pattern, match

DEFAULT_URL = "ws://127.0.0.1:9090"
BUILTIN_VARIABLES = ("ns", "ns_rel")
EXPECT_MS = 2000
EXPECT_NONE_MS = 300
MAX_WAIT_MS = 30_000
MAX_SLEEP_MS = 10_000
MAX_FRAGMENTS = 10_000
MAX_INBOX = 10_000
MAX_FRAME_BYTES = 64 * 2**20
CONNECT_TIMEOUT_S = 5.0
CASE_TIMEOUT_S = 120.0

PLACEHOLDER = re.compile(r"\$\{([^}]*)\}")
EXPECTS = ("expect", "expect_none", "expect_png", "expect_cbor", "expect_fragments")
STEP_FIELDS: dict[str, frozenset[str]] = {
    "send": frozenset({"client"}),
    "send_raw": frozenset({"client"}),
    "send_fragmented": frozenset({"client", "fragment_size", "reverse"}),
    "expect": frozenset({"client", "within_ms"}),
    "expect_none": frozenset({"client", "within_ms"}),
    "expect_png": frozenset({"client", "within_ms"}),
    "expect_cbor": frozenset({"client", "within_ms"}),
    "expect_fragments": frozenset({"client", "within_ms", "max_data_len"}),
    "close": frozenset(),
    "sleep_ms": frozenset(),
}
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# RFC 8746 typed arrays: tag -> struct byte order and item code.
TYPED_ARRAYS: dict[int, tuple[str, str]] = {
    64: ("<", "B"), 65: (">", "H"), 66: (">", "I"), 67: (">", "Q"),
    68: ("<", "B"), 69: ("<", "H"), 70: ("<", "I"), 71: ("<", "Q"),
    72: ("<", "b"), 73: (">", "h"), 74: (">", "i"), 75: (">", "q"),
    77: ("<", "h"), 78: ("<", "i"), 79: ("<", "q"),
    80: (">", "e"), 81: (">", "f"), 82: (">", "d"),
    84: ("<", "e"), 85: ("<", "f"), 86: ("<", "d"),
}  # fmt: skip


def default_vectors() -> Path:
    """The checkout's ``protocol/vectors``, else the copy an installed wheel ships."""
    package = Path(__file__).resolve().parents[1]
    repo = package.parent / "protocol" / "vectors"
    return repo if repo.is_dir() else package / "_protocol" / "vectors"


class VectorError(ValueError):
    """A vector file or case is malformed."""


class StepFailure(Exception):
    """The server did not behave as a step requires."""


# --------------------------------------------------------------------------- loading vectors


@dataclass(frozen=True)
class Case:
    name: str
    clients: tuple[str, ...]
    steps: tuple[dict, ...]
    source: str


def step_kind(step: Any) -> str:
    """The kind of a step (its action key); raises :class:`VectorError` when it has none or
    several, or fields that kind does not take."""
    if not isinstance(step, dict):
        raise VectorError("a step must be an object")
    kinds = [key for key in STEP_FIELDS if key in step]
    if len(kinds) != 1:
        raise VectorError(f"a step needs exactly one of {', '.join(STEP_FIELDS)}; got {kinds}")
    kind = kinds[0]
    extra = set(step) - STEP_FIELDS[kind] - {kind, "note"}
    if extra:
        raise VectorError(f"{kind} step has unknown field(s) {sorted(extra)}")
    return kind


def _int_field(step: dict, key: str, low: int, high: int, required: bool = False) -> None:
    if key not in step:
        if required:
            raise VectorError(f"missing '{key}'")
        return
    value = step[key]
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise VectorError(f"'{key}' must be an integer in {low}..{high}")


def _placeholders(value: Any) -> set[str]:
    if isinstance(value, str):
        return set(PLACEHOLDER.findall(value))
    if isinstance(value, list):
        return set().union(*map(_placeholders, value)) if value else set()
    if isinstance(value, dict):
        return set().union(*map(_placeholders, value.values())) if value else set()
    return set()


def _check_step(step: Any, clients: Sequence[str], known: set[str]) -> None:
    """Validate one step; adds the variables it captures to ``known``."""
    kind = step_kind(step)
    if "note" in step and not isinstance(step["note"], str):
        raise VectorError("'note' must be a string")
    if kind == "sleep_ms":
        _int_field(step, "sleep_ms", 0, MAX_SLEEP_MS)
        return
    target = step["close"] if kind == "close" else step.get("client")
    if target not in clients:
        raise VectorError(f"{kind} step names unknown client {target!r}")
    if kind == "close":
        return
    body = step[kind]
    unknown = _placeholders(body) - known
    if unknown:
        raise VectorError(f"unknown placeholder(s) {sorted(unknown)}")
    if kind == "send" and not isinstance(body, dict):
        raise VectorError("'send' must be an object")
    if kind == "send_raw" and not isinstance(body, str):
        raise VectorError("'send_raw' must be a string")
    if kind == "send_fragmented":
        if not isinstance(body, dict) or "op" not in body:
            raise VectorError("'send_fragmented' must be an op object")
        _int_field(step, "fragment_size", 1, 1_000_000, required=True)
        if not isinstance(step.get("reverse", False), bool):
            raise VectorError("'reverse' must be a boolean")
    if kind in EXPECTS:
        _int_field(step, "within_ms", 1, MAX_WAIT_MS)
        _int_field(step, "max_data_len", 1, 1_000_000)
        try:
            captured = check_pattern(body)
        except PatternError as exc:
            raise VectorError(f"bad pattern: {exc}") from None
        if captured and kind == "expect_none":
            raise VectorError("expect_none cannot capture")
        known.update(captured)


def check_case(raw: Any, source: str) -> Case:
    """Validate one case object and return it as a :class:`Case`."""
    if not isinstance(raw, dict):
        raise VectorError(f"{source}: a case must be an object")
    name = raw.get("name")
    if not isinstance(name, str) or not name:
        raise VectorError(f"{source}: a case needs a non-empty string 'name'")
    extra = set(raw) - {"name", "description", "clients", "steps"}
    if extra:
        raise VectorError(f"{source}: case {name}: unknown field(s) {sorted(extra)}")
    clients = raw.get("clients")
    if (
        not isinstance(clients, list)
        or not clients
        or not all(isinstance(c, str) and c for c in clients)
        or len(set(clients)) != len(clients)
    ):
        raise VectorError(f"{source}: case {name}: 'clients' must list distinct names")
    steps = raw.get("steps")
    if not isinstance(steps, list) or not steps:
        raise VectorError(f"{source}: case {name}: 'steps' must be a non-empty list")
    known = set(BUILTIN_VARIABLES)
    for index, step in enumerate(steps, 1):
        try:
            _check_step(step, clients, known)
        except VectorError as exc:
            raise VectorError(f"{source}: case {name}: step {index}: {exc}") from None
    return Case(name, tuple(clients), tuple(steps), source)


def load_file(path: Path) -> list[Case]:
    """The cases of one vector file."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise VectorError(f"{path}: {exc}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("cases"), list):
        raise VectorError(f"{path}: expected an object with a 'cases' list")
    extra = set(doc) - {"description", "cases"}
    if extra:
        raise VectorError(f"{path}: unknown top-level field(s) {sorted(extra)}")
    return [check_case(case, path.name) for case in doc["cases"]]


def load_cases(path: Path) -> list[Case]:
    """All cases of a vector file, or of every ``*.json`` in a directory (sorted by file name).

    Case names must be unique, because they are how results are reported.
    """
    files = sorted(path.glob("*.json")) if path.is_dir() else [path]
    if not files:
        raise VectorError(f"{path}: no vector files")
    cases: list[Case] = []
    seen: set[str] = set()
    for file in files:
        for case in load_file(file):
            if case.name in seen:
                raise VectorError(f"{file.name}: duplicate case name {case.name!r}")
            seen.add(case.name)
            cases.append(case)
    return cases


# --------------------------------------------------------------------------- wire helpers


def substitute(value: Any, variables: dict[str, Any]) -> Any:
    """Replace ``${name}`` placeholders in every string of ``value``."""
    if isinstance(value, str):
        whole = PLACEHOLDER.fullmatch(value)
        try:
            if whole:
                return variables[whole.group(1)]
            return PLACEHOLDER.sub(lambda m: str(variables[m.group(1)]), value)
        except KeyError as exc:
            raise StepFailure(f"placeholder ${{{exc.args[0]}}} has no value") from None
    if isinstance(value, list):
        return [substitute(item, variables) for item in value]
    if isinstance(value, dict):
        return {key: substitute(item, variables) for key, item in value.items()}
    return value


def fragment_texts(op: dict, size: int, frag_id: str, reverse: bool = False) -> list[str]:
    """The ``fragment`` ops (as JSON texts) that carry ``op`` in pieces of ``size`` characters."""
    text = json.dumps(op, separators=(",", ":"))
    pieces = [text[i : i + size] for i in range(0, len(text), size)]
    if len(pieces) > MAX_FRAGMENTS:
        raise StepFailure(f"{len(pieces)} fragments is more than {MAX_FRAGMENTS}")
    frames = [
        json.dumps({"op": "fragment", "id": frag_id, "data": piece, "num": num,
                    "total": len(pieces)})
        for num, piece in enumerate(pieces)
    ]  # fmt: skip
    return frames[::-1] if reverse else frames


def decode_png(data: Any) -> Any:
    """Decode the ``data`` of a ``png`` op back into the op it carries.

    Checks what the protocol promises: standard base64 of an 8-bit RGB PNG whose width is
    ``floor(sqrt(n / 3))`` and height ``ceil(n / 3 / width)`` for ``n`` bytes of JSON, padded
    with newlines, and JSON that is pure ASCII.
    """
    if not isinstance(data, str):
        raise ValueError("'data' is not a string")
    raw = base64.b64decode(data, validate=True)
    if raw[:8] != PNG_SIGNATURE or raw[12:16] != b"IHDR":
        raise ValueError("not a PNG image")
    width, height = struct.unpack(">II", raw[16:24])
    depth, colour = raw[24], raw[25]
    if (depth, colour) != (8, 2):
        raise ValueError(f"not 8-bit RGB (bit depth {depth}, colour type {colour})")
    with Image.open(io.BytesIO(raw)) as image:
        pixels = image.tobytes()
    text = pixels.rstrip(b"\n")
    n = len(text)
    want_width = math.isqrt(n // 3)
    if want_width == 0:
        raise ValueError(f"only {n} bytes of text")
    want = (want_width, -(-n // (3 * want_width)))
    if (width, height) != want:
        raise ValueError(f"image is {width}x{height}, expected {want[0]}x{want[1]} for {n} bytes")
    try:
        return json.loads(text.decode("ascii"))
    except UnicodeDecodeError:
        raise ValueError("the JSON inside is not ASCII") from None


class TypedArray(list):
    """A list decoded from an RFC 8746 typed array; ``cbor_tag`` keeps the tag for ``$tag``."""

    cbor_tag: int = 0


def _untag(value: Any) -> Any:
    if isinstance(value, cbor2.CBORTag) and value.tag in TYPED_ARRAYS:
        payload = value.value
        order, code = TYPED_ARRAYS[value.tag]
        size = struct.calcsize(order + code)
        if not isinstance(payload, bytes) or len(payload) % size:
            raise ValueError(f"typed array tag {value.tag} over {len(payload)} bytes")
        array = TypedArray(struct.unpack(f"{order}{len(payload) // size}{code}", payload))
        array.cbor_tag = value.tag
        return array
    if isinstance(value, dict):
        return {key: _untag(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_untag(item) for item in value]
    return value


def decode_cbor(data: bytes) -> Any:
    """Decode a binary frame, turning typed arrays into :class:`TypedArray` lists."""
    return _untag(cbor2.loads(data))


# --------------------------------------------------------------------------- clients


@dataclass
class Frame:
    """One received frame; ``value`` is the decoded JSON when ``is_json``.

    ``decoded`` caches what each expect kind made of the frame, so that re-scanning the inbox on
    every arrival does not decode a PNG or CBOR frame again.
    """

    text: str | None = None
    data: bytes | None = None
    value: Any = None
    is_json: bool = False
    decoded: dict[str, tuple[Any] | None] = field(default_factory=dict)


class Client:
    """One WebSocket connection with an inbox that expect steps search."""

    def __init__(self, name: str, ws: ClientConnection) -> None:
        self.name = name
        self.ws = ws
        self.inbox: list[Frame] = []
        self.closed_by_us = False
        self.reader_done = False
        self._arrived = asyncio.Event()
        self._reader = asyncio.create_task(self._read())

    @classmethod
    async def open(cls, name: str, url: str) -> Client:
        ws = await connect(
            url, open_timeout=CONNECT_TIMEOUT_S, max_size=MAX_FRAME_BYTES, proxy=None
        )
        return cls(name, ws)

    async def _read(self) -> None:
        try:
            async for message in self.ws:
                self._store(message)
        except ConnectionClosed:
            pass
        finally:
            self.reader_done = True
            self._arrived.set()

    def _store(self, message: str | bytes) -> None:
        if isinstance(message, bytes):
            frame = Frame(data=message)
        else:
            frame = Frame(text=message)
            with contextlib.suppress(ValueError):
                frame.value, frame.is_json = json.loads(message), True
        if len(self.inbox) >= MAX_INBOX:
            del self.inbox[0]
        self.inbox.append(frame)
        self._arrived.set()

    def close_description(self) -> str:
        code, reason = self.ws.close_code, self.ws.close_reason
        return f"code {code}" + (f": {reason}" if reason else "")

    async def send(self, text: str) -> None:
        if self.closed_by_us:
            raise StepFailure(f"client {self.name} was closed by an earlier step")
        try:
            await self.ws.send(text)
        except ConnectionClosed:
            raise StepFailure(
                f"client {self.name}: connection closed ({self.close_description()})"
            ) from None

    async def wait_for(self, find: Callable[[], Any], within_s: float) -> Any:
        """Call ``find`` on each arrival until it returns something other than ``None``, or
        until ``within_s`` seconds pass or the connection ends (then return ``None``)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + within_s
        while True:
            self._arrived.clear()
            found = find()
            remaining = deadline - loop.time()
            if found is not None or remaining <= 0 or self.reader_done:
                return found
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._arrived.wait(), remaining)

    async def close(self) -> None:
        self.closed_by_us = True
        with contextlib.suppress(TimeoutError, ConnectionClosed, OSError):
            await asyncio.wait_for(self.ws.close(), CONNECT_TIMEOUT_S)
        self._reader.cancel()


# --------------------------------------------------------------------------- expectations


def _describe(value: Any, limit: int = 160) -> str:
    text = json.dumps(value, default=repr) if not isinstance(value, str) else value
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _decoded(frame: Frame, kind: str) -> tuple[Any] | None:
    """The op a frame carries for an expect of ``kind`` (as a 1-tuple, since the op may be JSON
    ``null``), or ``None`` when it carries none. Cached on the frame."""
    if kind not in frame.decoded:
        frame.decoded[kind] = _decode(frame, kind)
    return frame.decoded[kind]


def _decode(frame: Frame, kind: str) -> tuple[Any] | None:
    """Uncached :func:`_decoded`. A ``png`` op or binary frame that cannot be decoded fails the
    step: the server sent it, so it must be valid."""
    try:
        if kind == "expect_png":
            if frame.is_json and isinstance(frame.value, dict) and frame.value.get("op") == "png":
                return (decode_png(frame.value.get("data")),)
            return None
        if kind == "expect_cbor":
            return (decode_cbor(frame.data),) if frame.data is not None else None
    except (ValueError, cbor2.CBORDecodeError) as exc:
        raise StepFailure(f"undecodable {kind.removeprefix('expect_')} frame: {exc}") from None
    return (frame.value,) if frame.is_json else None


def _nearest(client: Client, pattern: Any, kind: str) -> str:
    """Why the most recent frame of the same op as the pattern did not match, for the report."""
    wanted = pattern.get("op") if isinstance(pattern, dict) else None
    reason = ""
    for frame in client.inbox:
        decoded = _decoded(frame, kind)
        if decoded is None:
            continue
        op = decoded[0].get("op") if isinstance(decoded[0], dict) else None
        if wanted is None or op == wanted:
            reason = match(pattern, decoded[0]) or reason
    return f"; nearest: {reason}" if reason else ""


async def expect(client: Client, kind: str, pattern: Any, within_s: float, found: dict) -> None:
    """Wait for and consume the first frame whose decoded op matches ``pattern``."""

    def find() -> int | None:
        for index, frame in enumerate(client.inbox):
            decoded = _decoded(frame, kind)
            if decoded is not None and match(pattern, decoded[0], found) is None:
                return index
        return None

    index = await client.wait_for(find, within_s)
    if index is None:
        raise StepFailure(
            f"no match for {_describe(pattern)} within {round(within_s * 1000)} ms "
            f"({len(client.inbox)} unmatched frames){_nearest(client, pattern, kind)}"
        )
    del client.inbox[index]


async def expect_none(client: Client, pattern: Any, within_s: float) -> None:
    """Fail when a JSON frame matching ``pattern`` is waiting or arrives within the window."""

    def find() -> Any:
        for frame in client.inbox:
            if frame.is_json and match(pattern, frame.value) is None:
                return frame
        return None

    frame = await client.wait_for(find, within_s)
    if frame is not None:
        raise StepFailure(f"unexpected {_describe(frame.value)}")


def _fragment_shape(value: dict) -> str | None:
    """What is wrong with a ``fragment`` op's fields, or ``None``."""
    frag_id, num, total = value.get("id"), value.get("num"), value.get("total")
    if not isinstance(frag_id, str) or not frag_id:
        return f"id must be a non-empty string, got {frag_id!r}"
    for key, number in (("num", num), ("total", total)):
        if isinstance(number, bool) or not isinstance(number, int):
            return f"{key} must be an integer, got {number!r}"
    if not isinstance(value.get("data"), str):
        return "data must be a string"
    if not 0 <= num < total:
        return f"num {num} is outside 0..{total - 1}"
    return None


async def expect_fragments(
    client: Client, pattern: Any, within_s: float, max_len: int | None, found: dict
) -> None:
    """Wait for a complete fragment set whose joined text matches; consume its fragments."""

    def find() -> list[int] | None:
        groups: dict[str, dict[int, int]] = {}
        totals: dict[str, int] = {}
        for index, frame in enumerate(client.inbox):
            value = frame.value
            if not (frame.is_json and isinstance(value, dict) and value.get("op") == "fragment"):
                continue
            problem = _fragment_shape(value)
            if problem is None and totals.setdefault(value["id"], value["total"]) != value["total"]:
                problem = f"total changed within id {value['id']!r}"
            if problem is None and value["num"] in groups.get(value["id"], {}):
                problem = f"num {value['num']} repeated within id {value['id']!r}"
            if problem is not None:
                raise StepFailure(f"malformed fragment {_describe(value)}: {problem}")
            group = groups.setdefault(value["id"], {})
            group[value["num"]] = index
            if len(group) < value["total"]:
                continue
            datas = [client.inbox[group[num]].value["data"] for num in range(value["total"])]
            try:
                joined = json.loads("".join(datas))
            except ValueError as exc:
                raise StepFailure(f"fragments {value['id']!r} do not join to JSON: {exc}") from None
            if match(pattern, joined, found) is None:
                longest = max(len(data) for data in datas)
                if max_len is not None and longest > max_len:
                    raise StepFailure(f"a fragment carries {longest} characters, over {max_len}")
                return sorted(group.values())
        return None

    indices = await client.wait_for(find, within_s)
    if indices is None:
        raise StepFailure(
            f"no complete fragment set matching {_describe(pattern)} within "
            f"{round(within_s * 1000)} ms ({len(client.inbox)} unmatched frames)"
        )
    for index in reversed(indices):
        del client.inbox[index]


# --------------------------------------------------------------------------- running


@dataclass(frozen=True)
class Result:
    name: str
    passed: bool
    detail: str


class _Run:
    """The state of one case run: its clients and variables."""

    def __init__(self, scale: float) -> None:
        token = secrets.token_hex(4)
        self.variables: dict[str, Any] = {"ns": f"/conf_{token}", "ns_rel": f"conf_{token}"}
        self.clients: dict[str, Client] = {}
        self.scale = scale
        self.fragment_ids = 0

    async def step(self, step: dict) -> None:
        kind = step_kind(step)
        if kind == "sleep_ms":
            await asyncio.sleep(step["sleep_ms"] * self.scale / 1000)
            return
        if kind == "close":
            await self.clients[step["close"]].close()
            return
        client = self.clients[step["client"]]
        body = substitute(step[kind], self.variables)
        if kind == "send":
            await client.send(json.dumps(body))
        elif kind == "send_raw":
            await client.send(body)
        elif kind == "send_fragmented":
            self.fragment_ids += 1
            frag_id = f"conformance-{self.fragment_ids}"
            for text in fragment_texts(body, step["fragment_size"], frag_id, step.get("reverse")):
                await client.send(text)
        else:
            default = EXPECT_NONE_MS if kind == "expect_none" else EXPECT_MS
            within_s = step.get("within_ms", default) * self.scale / 1000
            if client.closed_by_us:
                raise StepFailure(f"client {client.name} was closed by an earlier step")
            found: dict[str, Any] = {}
            if kind == "expect_none":
                await expect_none(client, body, within_s)
            elif kind == "expect_fragments":
                await expect_fragments(client, body, within_s, step.get("max_data_len"), found)
            else:
                await expect(client, kind, body, within_s, found)
            self.variables.update(found)

    def server_closed(self) -> str | None:
        for client in self.clients.values():
            if client.reader_done and not client.closed_by_us:
                return f"server closed client {client.name} ({client.close_description()})"
        return None


def _step_label(index: int, step: dict) -> str:
    kind = step_kind(step)
    who = step.get("client") or step.get("close")
    return f"step {index} {kind}" + (f" {who}" if who and kind != "close" else "")


async def run_case(case: Case, url: str, scale: float = 1.0) -> Result:
    """Run one case on fresh connections and report whether it passed."""
    run = _Run(scale)
    try:
        async with asyncio.timeout(CASE_TIMEOUT_S * scale):
            for name in case.clients:
                try:
                    run.clients[name] = await Client.open(name, url)
                except (OSError, TimeoutError, WebSocketException) as exc:
                    return Result(case.name, False, f"cannot connect client {name}: {exc}")
            for index, step in enumerate(case.steps, 1):
                try:
                    await run.step(step)
                except StepFailure as exc:
                    return Result(case.name, False, f"{_step_label(index, step)}: {exc}")
                closed = run.server_closed()
                if closed:
                    return Result(case.name, False, f"after {_step_label(index, step)}: {closed}")
    except TimeoutError:
        return Result(case.name, False, f"case took longer than {CASE_TIMEOUT_S * scale:g} s")
    finally:
        for client in run.clients.values():
            await client.close()
    return Result(case.name, True, "")


def _row(name: str, result: str, detail: str, width: int) -> str:
    return f"{name:<{width}} | {result:<6} | {detail}".rstrip()


async def run_cases(
    cases: Sequence[Case], url: str, scale: float = 1.0, out: Any = None
) -> list[Result]:
    """Run cases one after another, printing the table rows to ``out`` as they finish."""
    width = max([len("name"), *(len(case.name) for case in cases)])
    if out is not None:
        print(_row("name", "result", "detail", width), file=out)
        print(f"{'-' * width}-|--------|-------", file=out, flush=True)
    results = []
    for case in cases:
        result = await run_case(case, url, scale)
        results.append(result)
        if out is not None:
            detail = " ".join(result.detail.split())
            row = _row(result.name, "pass" if result.passed else "FAIL", detail, width)
            print(row, file=out, flush=True)
    return results


def summary(results: Sequence[Result]) -> str:
    passed = sum(result.passed for result in results)
    return f"{passed} passed, {len(results) - passed} failed"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hitrobot-server conformance",
        description="Check a rosbridge-v2 (hitrobot protocol) server against the vectors.",
    )
    parser.add_argument("--url", default=DEFAULT_URL, help=f"server URL (default {DEFAULT_URL})")
    parser.add_argument(
        "--vectors",
        type=Path,
        default=None,
        help="a vector file or a directory of them (default: the protocol/vectors shipped with "
        "hitrobot-server)",
    )
    parser.add_argument(
        "--only",
        action="append",
        default=[],
        metavar="TEXT",
        help="run only cases whose name contains TEXT (repeatable)",
    )
    parser.add_argument(
        "--timeout-scale",
        type=float,
        default=1.0,
        metavar="FACTOR",
        help="multiply every wait and sleep by FACTOR (for slow machines)",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit code."""
    args = _parser().parse_args(argv)
    if not 0.1 <= args.timeout_scale <= 20:
        print("--timeout-scale must be between 0.1 and 20", file=sys.stderr)
        return 2
    try:
        cases = load_cases(args.vectors or default_vectors())
    except VectorError as exc:
        print(f"cannot load vectors: {exc}", file=sys.stderr)
        return 2
    if args.only:
        cases = [case for case in cases if any(text in case.name for text in args.only)]
        if not cases:
            print("no case matches --only", file=sys.stderr)
            return 2
    results = asyncio.run(run_cases(cases, args.url, args.timeout_scale, sys.stdout))
    print(summary(results))
    return 0 if all(result.passed for result in results) else 1


if __name__ == "__main__":
    sys.exit(main())

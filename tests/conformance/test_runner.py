"""The conformance runner against a scripted loopback server, plus its decoders.

The fake server does not implement the protocol; it does what each op tells it (reply with
this, as PNG, as CBOR, as fragments, close), so every step kind and failure path of the runner
can be driven precisely.
"""

from __future__ import annotations

import asyncio
import base64
import io
import json
import math
import socket
import struct
from collections.abc import AsyncIterator
from pathlib import Path

import cbor2
import pytest
from PIL import Image
from websockets.asyncio.server import ServerConnection, serve

from hitrobot_server.conformance.runner import (
    StepFailure,
    check_case,
    decode_cbor,
    decode_png,
    fragment_texts,
    main,
    run_case,
    run_cases,
    substitute,
    summary,
)


def encode_png(text: str, width: int | None = None, mode: str = "RGB") -> str:
    """The protocol's PNG packing of ``text`` (optionally with a wrong width or pixel mode)."""
    raw = text.encode("utf-8")
    channels = len(mode)
    width = width or math.isqrt(len(raw) // 3)
    height = -(-len(raw) // (channels * width))
    padded = raw + b"\n" * (width * height * channels - len(raw))
    buffer = io.BytesIO()
    Image.frombytes(mode, (width, height), padded).save(buffer, "PNG")
    return base64.b64encode(buffer.getvalue()).decode("ascii")


async def _fake(ws: ServerConnection) -> None:
    parts: dict[str, dict[int, str]] = {}
    async for text in ws:
        try:
            op = json.loads(text)
        except ValueError:
            await ws.send(json.dumps({"op": "status", "level": "error", "msg": "invalid JSON"}))
            continue
        await _handle(ws, op, parts)


async def _handle(ws: ServerConnection, op: dict, parts: dict[str, dict[int, str]]) -> None:
    kind = op.get("op")
    body = op.get("with")
    if kind == "fragment":
        group = parts.setdefault(op["id"], {})
        group[op["num"]] = op["data"]
        if len(group) == op["total"]:
            del parts[op["id"]]
            joined = "".join(group[num] for num in range(op["total"]))
            await _handle(ws, json.loads(joined), parts)
    elif kind == "reply":
        for item in body:
            await ws.send(json.dumps(item))
    elif kind == "reply_png":
        data = encode_png(json.dumps(body), op.get("width"), op.get("mode", "RGB"))
        await ws.send(json.dumps({"op": "png", "data": data}))
    elif kind == "reply_scan_cbor":
        ranges = cbor2.CBORTag(85, struct.pack("<3f", 1.5, 2.0, 0.25))
        msg = {"ranges": ranges, "raw": b"\x01\x02\x03", "count": 3}
        await ws.send(cbor2.dumps({"op": "publish", "topic": "/scan", "msg": msg}))
    elif kind == "reply_fragments":
        frames = fragment_texts(body, op["size"], op.get("frag_id", "f-1"), reverse=True)
        for frame in frames:
            await ws.send(frame)
    elif kind == "reply_later":
        await asyncio.sleep(op["ms"] / 1000)
        await ws.send(json.dumps(body))
    elif kind == "close":
        await ws.close(1011, "told to")
    else:
        await ws.send(json.dumps({"op": "status", "level": "error", "msg": f"unknown op {kind}"}))


@pytest.fixture
async def url() -> AsyncIterator[str]:
    async with serve(_fake, "127.0.0.1", 0) as server:
        port = server.sockets[0].getsockname()[1]
        yield f"ws://127.0.0.1:{port}"


def _case(*steps: dict, clients: tuple[str, ...] = ("a",)):
    return check_case({"name": "case", "clients": list(clients), "steps": list(steps)}, "t.json")


def _send(op: dict, client: str = "a") -> dict:
    return {"client": client, "send": op}


def _reply(*items: dict) -> dict:
    return {"op": "reply", "with": list(items)}


async def test_a_case_using_every_step_kind_passes(url: str):
    case = _case(
        {"client": "a", "send_raw": "{not json", "note": "garbage first"},
        {"client": "a", "expect": {"op": "status", "msg": {"$regex": "(?i)invalid json"}}},
        _send(_reply({"op": "call_service", "id": "service_request:${ns}/s:1"})),
        {"client": "a", "expect": {"op": "call_service", "id": {"$capture": "req"}}},
        _send(_reply({"op": "echo", "id": "${req}", "ns": "${ns_rel}"})),
        {"client": "a", "expect": {"op": "echo", "id": {"$regex": "^service_request:/conf_"}}},
        {
            "client": "a",
            "send_fragmented": _reply({"op": "joined", "text": "x" * 40}),
            "fragment_size": 9,
            "reverse": True,
        },
        {"client": "a", "expect": {"op": "joined", "text": {"$len": 40}}},
        _send({"op": "reply_png", "with": {"op": "publish", "msg": {"data": "café"}}}),
        {"client": "a", "expect_png": {"op": "publish", "msg": {"data": "café"}}},
        _send({"op": "reply_scan_cbor"}),
        {
            "client": "a",
            "expect_cbor": {
                "topic": "/scan",
                "msg": {
                    "ranges": {"$tag": 85, "$match": [1.5, 2.0, 0.25]},
                    "raw": {"$type": "bytes"},
                },
            },
        },
        _send({"op": "reply_fragments", "size": 10, "with": {"op": "publish", "msg": "m" * 50}}),
        {
            "client": "a",
            "expect_fragments": {"op": "publish", "msg": {"$len": 50}},
            "max_data_len": 10,
        },
        {"client": "a", "expect_none": {"op": "fragment"}, "within_ms": 50},
        {"sleep_ms": 10},
        {"close": "a"},
    )
    result = await run_case(case, url)
    assert (result.passed, result.detail) == (True, "")


async def test_expect_skips_unrelated_frames_and_leaves_them_for_later(url: str):
    case = _case(
        _send(_reply({"op": "status", "n": 1}, {"op": "other"}, {"op": "wanted"})),
        {"client": "a", "expect": {"op": "wanted"}},
        {"client": "a", "expect": {"op": "status", "n": 1}},
        {"client": "a", "expect_none": {"op": "wanted"}, "within_ms": 50},
    )
    assert (await run_case(case, url)).passed


async def test_timeout_names_the_step_and_the_nearest_mismatch(url: str):
    case = _case(
        _send(_reply({"op": "publish", "msg": {"data": "b"}})),
        {"client": "a", "expect": {"op": "publish", "msg": {"data": "a"}}, "within_ms": 100},
    )
    result = await run_case(case, url)
    assert not result.passed
    assert result.detail.startswith("step 2 expect a: no match for")
    assert "within 100 ms" in result.detail
    assert "nearest: $.msg.data: expected 'a', got 'b'" in result.detail


async def test_expect_waits_for_late_frames(url: str):
    case = _case(
        _send({"op": "reply_later", "ms": 150, "with": {"op": "late"}}),
        {"client": "a", "expect": {"op": "late"}, "within_ms": 2000},
    )
    assert (await run_case(case, url)).passed


async def test_expect_none_fails_when_a_match_arrives(url: str):
    case = _case(
        _send({"op": "reply_later", "ms": 50, "with": {"op": "status", "level": "error"}}),
        {"client": "a", "expect_none": {"op": "status"}, "within_ms": 1000},
    )
    result = await run_case(case, url)
    assert not result.passed
    assert "step 2 expect_none a: unexpected" in result.detail


async def test_a_connection_closed_by_the_server_fails_the_case(url: str):
    case = _case(_send({"op": "close"}), {"sleep_ms": 100}, _send({"op": "reply", "with": []}))
    result = await run_case(case, url)
    assert not result.passed
    assert "server closed client a (code 1011: told to)" in result.detail


async def test_closing_our_own_client_is_fine_but_it_cannot_be_used_after(url: str):
    case = _case({"close": "b"}, _send(_reply({"op": "x"}), "b"), clients=("a", "b"))
    result = await run_case(case, url)
    assert "client b was closed by an earlier step" in result.detail


async def test_png_of_the_wrong_size_fails(url: str):
    body = {"op": "publish", "msg": {"data": "y" * 30}}
    case = _case(
        _send({"op": "reply_png", "width": 3, "with": body}),
        {"client": "a", "expect_png": {"op": "publish"}},
    )
    result = await run_case(case, url)
    assert "undecodable png frame: image is 3x" in result.detail


async def test_malformed_fragments_fail(url: str):
    bad = {"op": "fragment", "id": "x", "data": "{}", "num": 0, "total": 1.0}
    case = _case(_send(_reply(bad)), {"client": "a", "expect_fragments": {}})
    result = await run_case(case, url)
    assert "malformed fragment" in result.detail
    assert "total must be an integer" in result.detail


async def test_fragments_longer_than_allowed_fail(url: str):
    case = _case(
        _send({"op": "reply_fragments", "size": 20, "with": {"op": "publish", "msg": "m" * 50}}),
        {"client": "a", "expect_fragments": {"op": "publish"}, "max_data_len": 10},
    )
    result = await run_case(case, url)
    assert "a fragment carries 20 characters, over 10" in result.detail


async def test_run_cases_prints_the_table_and_summary(url: str):
    good = _case(_send(_reply({"op": "x"})), {"client": "a", "expect": {"op": "x"}})
    bad = check_case(
        {
            "name": "a-much-longer-case-name",
            "clients": ["a"],
            "steps": [{"client": "a", "expect": {"op": "never"}, "within_ms": 20}],
        },
        "t.json",
    )
    out = io.StringIO()
    results = await run_cases([good, bad], url, out=out)
    lines = out.getvalue().splitlines()
    assert lines[0].split(" | ") == ["name                   ", "result", "detail"]
    assert lines[2].startswith("case                    | pass")
    assert lines[3].startswith("a-much-longer-case-name | FAIL   | step 1 expect a: no match")
    assert summary(results) == "1 passed, 1 failed"


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_main_reports_unreachable_servers_as_failures(tmp_path: Path, capsys):
    vectors = tmp_path / "v.json"
    case = {"name": "only", "clients": ["a"], "steps": [{"sleep_ms": 1}]}
    vectors.write_text(json.dumps({"cases": [case]}))
    code = main(["--url", f"ws://127.0.0.1:{_free_port()}", "--vectors", str(vectors)])
    lines = capsys.readouterr().out.splitlines()
    assert code == 1
    assert "cannot connect client a" in lines[2]
    assert lines[-1] == "0 passed, 1 failed"


def test_main_rejects_bad_vectors_and_empty_selections(tmp_path: Path, capsys):
    vectors = tmp_path / "v.json"
    vectors.write_text("{}")
    assert main(["--vectors", str(vectors)]) == 2
    assert "cannot load vectors" in capsys.readouterr().err
    vectors.write_text(
        json.dumps({"cases": [{"name": "n", "clients": ["a"], "steps": [{"sleep_ms": 1}]}]})
    )
    assert main(["--vectors", str(vectors), "--only", "zzz"]) == 2
    assert main(["--vectors", str(vectors), "--timeout-scale", "0"]) == 2


class TestDecoders:
    def test_png_round_trip(self):
        op = {"op": "publish", "topic": "/t", "msg": {"data": "hé"}}
        assert decode_png(encode_png(json.dumps(op))) == op

    @pytest.mark.parametrize(
        ("data", "complaint"),
        [
            (encode_png(json.dumps({"op": "p", "x": "y" * 20}), mode="RGBA"), "not 8-bit RGB"),
            (encode_png(json.dumps({"op": "p", "x": "é" * 20}, ensure_ascii=False)), "not ASCII"),
            (base64.b64encode(b"GIF89a" + b"\0" * 30).decode(), "not a PNG"),
            ("not base64!", "base64"),
            (5, "not a string"),
        ],
    )
    def test_png_violations(self, data, complaint):
        with pytest.raises(ValueError, match=complaint):
            decode_png(data)

    def test_cbor_typed_arrays_become_tagged_lists(self):
        payload = {
            "f32": cbor2.CBORTag(85, struct.pack("<2f", 0.5, -1.0)),
            "i32": cbor2.CBORTag(78, struct.pack("<2i", 1, -2)),
            "u16be": cbor2.CBORTag(65, struct.pack(">H", 258)),
            "nested": [{"u8": cbor2.CBORTag(64, b"\x01\x02")}],
            "bytes": b"\x00",
            "other": cbor2.CBORTag(1, 5),
        }
        decoded = decode_cbor(cbor2.dumps(payload))
        assert decoded["f32"] == [0.5, -1.0] and decoded["f32"].cbor_tag == 85
        assert decoded["i32"] == [1, -2] and decoded["i32"].cbor_tag == 78
        assert decoded["u16be"] == [258]
        assert decoded["nested"][0]["u8"] == [1, 2]
        assert decoded["bytes"] == b"\x00"

    def test_cbor_typed_array_of_a_partial_item_is_rejected(self):
        with pytest.raises(ValueError, match="tag 85 over 3 bytes"):
            decode_cbor(cbor2.dumps(cbor2.CBORTag(85, b"\x00\x00\x00")))


class TestHelpers:
    def test_fragment_texts_join_back_to_the_op(self):
        op = {"op": "publish", "msg": {"data": "z" * 25}}
        frames = [json.loads(text) for text in fragment_texts(op, 8, "id-1", reverse=True)]
        assert [frame["num"] for frame in frames] == list(range(len(frames)))[::-1]
        assert {frame["total"] for frame in frames} == {len(frames)}
        assert all(len(frame["data"]) <= 8 for frame in frames)
        joined = "".join(frame["data"] for frame in sorted(frames, key=lambda f: f["num"]))
        assert json.loads(joined) == op

    def test_substitute_keeps_the_type_of_a_whole_placeholder(self):
        variables = {"ns": "/conf_1", "req": 7}
        value = {"a": ["${ns}/t", "${req}", "id ${req}"], "b": 1}
        assert substitute(value, variables) == {"a": ["/conf_1/t", 7, "id 7"], "b": 1}

    def test_substitute_fails_on_a_missing_value(self):
        with pytest.raises(StepFailure, match="nope"):
            substitute("${nope}", {})

"""PNG compression must match rosbridge's pixels exactly, since roslibjs decodes them."""

import base64
import io
import math
import struct
import time

import orjson
import pytest
from PIL import Image

from hitrobot_server.protocol import png

# Worked by hand from rosbridge's formula: width = floor(sqrt(n/3)), height = ceil(n/3/width).
# n = 299: n/3 = 99.67, sqrt = 9.98 -> 9; 99.67 / 9 = 11.07 -> 12.
# n = 1000003: n/3 = 333334.33, sqrt = 577.35 -> 577; 333334.33 / 577 = 577.7 -> 578.
# n < 3 divides by zero in rosbridge; we use one pixel.
SIZES = {
    1: (1, 1),
    2: (1, 1),
    3: (1, 1),
    4: (1, 2),
    299: (9, 12),
    300: (10, 10),
    1000003: (577, 578),
}


def _chunks(raw: bytes) -> list[tuple[bytes, bytes]]:
    """(type, data) of every PNG chunk."""
    assert raw[:8] == b"\x89PNG\r\n\x1a\n"
    chunks, pos = [], 8
    while pos < len(raw):
        (length,) = struct.unpack(">I", raw[pos : pos + 4])
        chunks.append((raw[pos + 4 : pos + 8], raw[pos + 8 : pos + 8 + length]))
        pos += 12 + length
    return chunks


@pytest.mark.parametrize(("length", "size"), SIZES.items())
def test_image_size_follows_rosbridge_formula(length, size):
    assert png.image_size(length) == size
    if length >= 3:
        width = math.floor(math.sqrt(length / 3.0))
        assert size == (width, math.ceil((length / 3.0) / width))


@pytest.mark.parametrize("length", SIZES)
def test_pixels_are_data_padded_with_newlines(length):
    data = bytes((i * 7 + 32) % 127 for i in range(length))
    width, height = SIZES[length]
    raw = base64.standard_b64decode(png.encode(data))
    with Image.open(io.BytesIO(raw)) as image:
        assert image.mode == "RGB"
        assert image.size == (width, height)
        assert image.tobytes() == data + b"\n" * (width * height * 3 - length)


def test_png_is_plain_8bit_rgb_without_extra_chunks():
    raw = base64.standard_b64decode(png.encode(b'{"op":"publish","topic":"/a","msg":{}}'))
    chunks = _chunks(raw)
    kinds = [kind for kind, _ in chunks]
    assert kinds[0] == b"IHDR" and kinds[-1] == b"IEND"
    assert set(kinds) == {b"IHDR", b"IDAT", b"IEND"}
    width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", chunks[0][1])
    assert (width, height) == png.image_size(39)
    assert depth == 8
    assert colour == 2  # truecolour RGB, no alpha
    assert interlace == 0


def test_base64_is_standard_alphabet_with_padding():
    text = png.encode(b"x" * 1000)
    assert len(text) % 4 == 0
    assert set(text) <= set("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/=")


@pytest.mark.parametrize(
    "payload",
    [
        b"1",
        b"{}",
        b'{"op":"publish","topic":"/chatter","msg":{"data":"hi"}}',
        b'{"op":"publish","topic":"/t","msg":{"data":"caf\\u00e9 \\u4e2d"}}',
        b'{\n  "pretty": [1, 2, 3]\n}',
        orjson.dumps({"data": list(range(10000))}),
    ],
)
def test_round_trip(payload):
    assert png.decode(png.encode(payload)) == payload


def test_decode_strips_only_trailing_newlines():
    payload = b'{"a":\n1}'  # 8 bytes -> 1x3 pixels, one padding newline
    assert png.decode(png.encode(payload)) == payload


def test_png_op_is_the_whole_outgoing_message():
    payload = b'{"op":"publish","topic":"/map","msg":{"data":[0,100,-1]}}'
    op = orjson.loads(png.png_op(payload))
    assert set(op) == {"op", "data"}
    assert op["op"] == "png"
    assert png.decode(op["data"]) == payload


def test_large_occupancy_grid_round_trips():
    payload = orjson.dumps({"data": [0] * (4000 * 4000)})
    assert len(payload) > 32_000_000
    started = time.perf_counter()
    encoded = png.encode(payload)
    encode_seconds = time.perf_counter() - started
    print(f"png.encode of {len(payload)} bytes took {encode_seconds:.3f} s")
    assert png.decode(encoded) == payload


def _png_bytes(size: tuple[int, int], mode: str = "RGB") -> bytes:
    out = io.BytesIO()
    Image.new(mode, size).save(out, format="PNG")
    return out.getvalue()


def test_declared_size_reads_the_header_without_decoding():
    assert png.declared_size(_png_bytes((7, 5))) == (7, 5, 3)
    assert png.declared_size(_png_bytes((7, 5), "RGBA")) == (7, 5, 4)
    assert png.declared_size(_png_bytes((7, 5), "L")) == (7, 5, 3)  # decoded as RGB
    # a header declaring 13000 x 13000 pixels: the bytes after it are never looked at
    bomb = _png_bytes((1, 1))[:16] + struct.pack(">II", 13000, 13000) + b"\x08\x02" + b"junk"
    assert png.declared_size(bomb) == (13000, 13000, 3)
    with pytest.raises(ValueError, match="13000x13000 pixels, 507000000 bytes"):
        png.check_size(bomb, 256 * 1024 * 1024)
    with pytest.raises(ValueError, match="not a PNG"):
        png.declared_size(b"GIF89a" + bytes(30))


def test_decode_refuses_an_image_over_the_limit_and_accepts_one_under_it():
    data = base64.b64encode(_png_bytes((100, 100))).decode()
    with pytest.raises(ValueError, match="more than the limit of 29999 bytes"):
        png.decode(data, max_bytes=29_999)
    assert len(png.decode(data, max_bytes=30_000).rstrip(b"\0")) == 0

"""rosbridge-compatible PNG "compression" of outgoing JSON.

The JSON text's bytes become the RGB pixels of an 8-bit truecolour PNG, as rosbridge's
``pngcompression.encode`` does, because roslibjs decodes exactly that: it reads R, G, B of every
pixel back as bytes (1.x as Latin-1 characters, 2.x as UTF-8) and parses them as JSON, to which
the trailing ``\\n`` padding is harmless whitespace. Callers pass ASCII JSON (non-ASCII
escaped), which both roslibjs decoders read correctly.
"""

from __future__ import annotations

import base64
import io
import math
import struct

from PIL import Image

_PAD = b"\n"


def image_size(length: int) -> tuple[int, int]:
    """Width and height of the image holding ``length`` bytes, by rosbridge's formula.

    rosbridge divides by a zero width when ``length < 3``; we use one pixel (width 1) instead.
    """
    pixels = length / 3.0
    width = max(math.floor(math.sqrt(pixels)), 1)
    height = max(math.ceil(pixels / width), 1)
    return width, height


def encode(data: bytes) -> str:
    """The base64 text (standard alphabet, padded) of the PNG holding ``data``."""
    width, height = image_size(len(data))
    padded = data + _PAD * (width * height * 3 - len(data))
    image = Image.frombytes("RGB", (width, height), padded)
    out = io.BytesIO()
    image.save(out, format="PNG")
    return base64.standard_b64encode(out.getvalue()).decode("ascii")


_SIGNATURE = b"\x89PNG\r\n\x1a\n"


_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # PNG colour type -> samples per pixel


def declared_size(data: bytes) -> tuple[int, int, int]:
    """Width, height and bytes per pixel (once decoded, at least the 3 of RGB) that a PNG's
    header (its first chunk, ``IHDR``) declares, read without decoding anything;
    ``ValueError`` when the header is not a PNG header."""
    if len(data) < 26 or not data.startswith(_SIGNATURE) or data[12:16] != b"IHDR":
        raise ValueError("not a PNG (no PNG signature and IHDR header)")
    width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
    per_pixel = _CHANNELS.get(colour, 4) * max(depth // 8, 1)
    return width, height, max(per_pixel, 3)


def check_size(data: bytes, max_bytes: int) -> None:
    """Refuse a PNG whose pixels would take more than ``max_bytes``, before decoding it:
    a few hundred kilobytes of compressed zeros can declare gigabytes of pixels."""
    width, height, per_pixel = declared_size(data)
    size = width * height * per_pixel
    if size > max_bytes:
        raise ValueError(
            f"the image is {width}x{height} pixels, {size} bytes once decoded, more than the "
            f"limit of {max_bytes} bytes"
        )


def decode(b64: str, max_bytes: int | None = None) -> bytes:
    """The bytes held by a PNG from :func:`encode`, without the ``\\n`` padding; with
    ``max_bytes``, a PNG declaring more pixel bytes is refused before it is decoded.

    Only trailing newlines are stripped (rosbridge strips every ``\\n``): padding is always at
    the end, and JSON text never needs a raw newline, so this is enough and never alters a
    payload that has newlines of its own inside.
    """
    data = base64.standard_b64decode(b64)
    if max_bytes is not None:
        check_size(data, max_bytes)
    with Image.open(io.BytesIO(data)) as image:
        pixels = image.convert("RGB").tobytes()
    return pixels.rstrip(_PAD)


def png_op(json_bytes: bytes) -> bytes:
    """The whole outgoing op ``{"op":"png","data":"…"}`` for the JSON text ``json_bytes``.

    rosbridge sends no ``id``, ``num`` or ``total``; a large result is split by ordinary
    ``fragment`` ops, never by ``png`` fragments, which no roslibjs version reassembles.
    """
    return b'{"op":"png","data":"' + encode(json_bytes).encode("ascii") + b'"}'

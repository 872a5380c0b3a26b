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


def decode(b64: str) -> bytes:
    """The bytes held by a PNG from :func:`encode`, without the ``\\n`` padding.

    Only trailing newlines are stripped (rosbridge strips every ``\\n``): padding is always at
    the end, and JSON text never needs a raw newline, so this is enough and never alters a
    payload that has newlines of its own inside.
    """
    with Image.open(io.BytesIO(base64.standard_b64decode(b64))) as image:
        pixels = image.convert("RGB").tobytes()
    return pixels.rstrip(_PAD)


def png_op(json_bytes: bytes) -> bytes:
    """The whole outgoing op ``{"op":"png","data":"…"}`` for the JSON text ``json_bytes``.

    rosbridge sends no ``id``, ``num`` or ``total``; a large result is split by ordinary
    ``fragment`` ops, never by ``png`` fragments, which no roslibjs version reassembles.
    """
    return b'{"op":"png","data":"' + encode(json_bytes).encode("ascii") + b'"}'

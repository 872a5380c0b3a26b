"""Incremental splitting of a TCP byte stream into JSON objects.

TCP clients send objects back to back (rosbridge's own clients add no delimiter), one per line,
or split anywhere, even inside a multi-byte UTF-8 character. The scanner works on the raw bytes:
``{``, ``}``, ``"`` and ``\\`` are ASCII and never occur inside a multi-byte UTF-8 sequence, so a
character split across reads needs no decoding state, and ``orjson`` validates the UTF-8 of each
complete object. Only bytes not scanned yet are looked at on each feed.

Only JSON objects are accepted at the top level. Recovery from broken input:

* Anything else between objects is reported once per run and skipped up to the next ``{``.
* A raw newline inside a string is never valid JSON (control characters must be escaped), so it
  marks an unterminated string: the object is reported and scanning restarts after the newline.
* A ``{`` that cannot start a value (not after ``[``, ``,`` or ``:``) ends a broken object: it
  is reported and a new object starts at that ``{``.
* An object whose braces balance but which does not parse is reported, and scanning continues
  after it.
* An object larger than ``max_message_size`` is reported once and its bytes are dropped while
  its braces are still tracked, so decoding resumes after its end. An object whose braces never
  balance therefore swallows input until it is over that size.
"""

from __future__ import annotations

import re

from ..types import jsoncodec
from .errors import ProtocolError

_NOT_SPACE = re.compile(rb"[^ \t\r\n]")
_STRUCTURE = re.compile(rb'[{}"]')
_STRING_STOP = re.compile(rb'["\\\n]')
_SPACE = b" \t\r\n"
_OPEN, _CLOSE, _QUOTE, _BACKSLASH = ord("{"), ord("}"), ord('"'), ord("\\")
_VALUE_STARTERS = b"[,:"


def _preview(data: bytes | bytearray, limit: int = 40) -> str:
    text = bytes(data[: limit * 4]).decode("utf-8", "replace")
    return repr(text[:limit] + ("…" if len(text) > limit or len(data) > limit * 4 else ""))


class JsonStreamDecoder:
    """Feed bytes in, get the complete top-level JSON values out, in order."""

    def __init__(self, max_message_size: int = 128 * 1024 * 1024) -> None:
        self.max_message_size = max_message_size
        self._buf = bytearray()
        self._pos = 0  # next byte to scan
        self._start = 0  # first byte of the object in progress (when depth > 0)
        self._depth = 0
        self._in_string = False
        self._escape = False  # a backslash ended the data inside a string
        self._discarding = False  # the object in progress is oversized and already reported

    @property
    def buffered(self) -> int:
        """Bytes held for an object not complete yet."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[object | ProtocolError]:
        """Add bytes; return every value completed by them, with a :class:`ProtocolError` in
        place of each invalid or oversized object and each run of stray data."""
        buf = self._buf
        buf += data
        out: list[object | ProtocolError] = []
        end = len(buf)
        pos = self._pos
        while pos < end:
            if self._depth == 0:
                pos = self._between_objects(pos, out)
            elif self._in_string:
                pos = self._in_string_at(pos, out)
            else:
                pos = self._in_object_at(pos, out)
        self._pos = pos
        if self._depth and not self._discarding and end - self._start > self.max_message_size:
            out.append(self._oversized())
            self._discarding = True
        self._compact()
        return out

    def _between_objects(self, pos: int, out: list) -> int:
        buf = self._buf
        match = _NOT_SPACE.search(buf, pos)
        if match is None:
            return len(buf)
        first = match.start()
        if buf[first] == _OPEN:
            self._start, self._depth = first, 1
            return first + 1
        stop = buf.find(b"{", first)
        stop = len(buf) if stop < 0 else stop
        out.append(
            ProtocolError(f"invalid JSON: expected a JSON object, got {_preview(buf[first:stop])}")
        )
        return stop

    def _in_string_at(self, pos: int, out: list) -> int:
        if self._escape:
            self._escape = False
            return pos + 1
        buf = self._buf
        match = _STRING_STOP.search(buf, pos)
        if match is None:
            return len(buf)
        i = match.start()
        char = buf[i]
        if char == _QUOTE:
            self._in_string = False
            return i + 1
        if char == _BACKSLASH:
            if i + 1 < len(buf):
                return i + 2
            self._escape = True
            return i + 1
        self._broken(i, "unterminated string (raw newline inside a string)", out)
        return i + 1

    def _in_object_at(self, pos: int, out: list) -> int:
        buf = self._buf
        match = _STRUCTURE.search(buf, pos)
        if match is None:
            return len(buf)
        i = match.start()
        char = buf[i]
        if char == _QUOTE:
            self._in_string = True
        elif char == _OPEN:
            if not self._discarding and not self._value_may_start(i):
                self._broken(i, "unexpected '{'", out)
                return i  # rescanned as the start of a new object
            self._depth += 1
        else:
            self._depth -= 1
            if self._depth == 0:
                self._complete(i + 1, out)
        return i + 1

    def _value_may_start(self, i: int) -> bool:
        """Whether a ``{`` at ``i`` inside an object follows ``[``, ``,`` or ``:``."""
        buf = self._buf
        j = i - 1
        while buf[j] in _SPACE:
            j -= 1
        return buf[j] in _VALUE_STARTERS

    def _complete(self, end: int, out: list) -> None:
        if self._discarding:
            self._discarding = False
            return
        if end - self._start > self.max_message_size:
            out.append(self._oversized())
            return
        try:
            out.append(jsoncodec.loads(self._buf[self._start : end]))
        except ValueError as exc:  # malformed, or a value jsoncodec.check_value refuses
            out.append(ProtocolError(f"invalid JSON: {exc}", getattr(exc, "id", None)))

    def _broken(self, i: int, reason: str, out: list) -> None:
        """Report the object in progress as broken at ``i`` and return to the top level."""
        if not self._discarding:
            text = _preview(self._buf[self._start : i])
            out.append(ProtocolError(f"invalid JSON: {reason} in {text}"))
        self._depth = 0
        self._in_string = self._escape = self._discarding = False

    def _oversized(self) -> ProtocolError:
        return ProtocolError(
            f"invalid JSON: message larger than the limit of {self.max_message_size} bytes"
        )

    def _compact(self) -> None:
        """Drop consumed bytes, and all bytes of an object being discarded."""
        if self._depth and self._discarding:
            keep = len(self._buf)
        elif self._depth:
            keep = self._start
        else:
            keep = self._pos
        if keep:
            del self._buf[:keep]
            self._pos -= keep
            self._start = 0

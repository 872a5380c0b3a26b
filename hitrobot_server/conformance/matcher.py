"""Pattern matching for conformance vectors.

A vector says what a server reply must look like without spelling out every field: a pattern
is JSON where objects match as a recursive *subset*, lists and scalars match exactly, and a
small set of ``$`` operators covers what literal JSON cannot say (a regular expression, a type,
"this key must be absent", "remember this value for a later step").

An object whose keys all start with ``$`` is an operator object; every operator in it must
hold. Mixing ``$`` keys and plain keys in one object is an error in the vector, not a
mismatch, so a typo cannot silently weaken a test.

Operators:

``{"$any": true}``         any value, including ``null`` (the key must be present)
``{"$absent": true}``      only as an object member: the key must not be present
``{"$type": T}``           T is string, number, integer, boolean, object, array, null or bytes
                           (number covers integers; booleans are never numbers)
``{"$regex": R}``          a string that ``re.search`` finds R in
``{"$contains": X}``       a string containing the substring X, or a list with an element
                           matching the pattern X
``{"$len": N}``            a string, list, object or byte string of length N
``{"$in": [P, ...]}``      matches at least one of the patterns
``{"$not": P}``            does not match the pattern P
``{"$gt": N}``, ``{"$lt": N}``  a number greater / less than N
``{"$tag": N}``            a list decoded from a CBOR typed array with tag N
``{"$match": P}``          matches the pattern P (to combine a literal with other operators)
``{"$capture": NAME}``     any value; on a successful match it is stored as ``NAME`` for the
                           ``${NAME}`` placeholders of later steps
"""

from __future__ import annotations

import re
from typing import Any

from ..protocol.ops import json_type

TYPE_NAMES = ("string", "number", "integer", "boolean", "object", "array", "null", "bytes")
OPERATORS = (
    "$any",
    "$absent",
    "$type",
    "$regex",
    "$contains",
    "$len",
    "$in",
    "$not",
    "$gt",
    "$lt",
    "$tag",
    "$match",
    "$capture",
)
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class PatternError(ValueError):
    """The pattern itself is malformed (a fault in the vector, not in the server)."""


def is_operator(pattern: Any) -> bool:
    """Whether ``pattern`` is an operator object (non-empty, every key starts with ``$``)."""
    return (
        isinstance(pattern, dict)
        and bool(pattern)
        and all(isinstance(k, str) and k.startswith("$") for k in pattern)
    )


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def check_pattern(pattern: Any, path: str = "$") -> list[str]:
    """Names of the variables the pattern captures; raises :class:`PatternError` when malformed.

    Called when vectors are loaded, so that a broken pattern fails loudly before any traffic.
    """
    captures: list[str] = []
    if isinstance(pattern, list):
        for i, item in enumerate(pattern):
            captures += check_pattern(item, f"{path}[{i}]")
        return captures
    if not isinstance(pattern, dict):
        if pattern is None or isinstance(pattern, bool | int | float | str):
            return captures
        raise PatternError(f"{path}: {type(pattern).__name__} is not JSON")
    dollar = [k for k in pattern if k.startswith("$")]
    if dollar and len(dollar) != len(pattern):
        raise PatternError(f"{path}: mixes operators {dollar} with plain keys")
    if not dollar:
        for key, sub in pattern.items():
            captures += check_pattern(sub, f"{path}.{key}")
        return captures
    for op, arg in pattern.items():
        captures += _check_operator(op, arg, path)
    if "$absent" in pattern and len(pattern) > 1:
        raise PatternError(f"{path}: $absent cannot be combined with other operators")
    return captures


def _check_operator(op: str, arg: Any, path: str) -> list[str]:
    where = f"{path}.{op}"
    if op not in OPERATORS:
        raise PatternError(f"{where}: unknown operator")
    if op in ("$any", "$absent") and arg is not True:
        raise PatternError(f"{where}: argument must be true")
    if op == "$type" and arg not in TYPE_NAMES:
        raise PatternError(f"{where}: type must be one of {', '.join(TYPE_NAMES)}")
    if op == "$regex":
        if not isinstance(arg, str):
            raise PatternError(f"{where}: argument must be a string")
        try:
            re.compile(arg)
        except re.error as exc:
            raise PatternError(f"{where}: bad regular expression: {exc}") from None
    if op in ("$len", "$tag") and not (isinstance(arg, int) and not isinstance(arg, bool)):
        raise PatternError(f"{where}: argument must be an integer")
    if op in ("$gt", "$lt") and not _is_number(arg):
        raise PatternError(f"{where}: argument must be a number")
    if op == "$capture" and not (isinstance(arg, str) and IDENTIFIER.fullmatch(arg)):
        raise PatternError(f"{where}: argument must be an identifier")
    if op == "$capture":
        return [arg]
    if op == "$in":
        if not isinstance(arg, list) or not arg:
            raise PatternError(f"{where}: argument must be a non-empty list")
        for i, item in enumerate(arg):
            if check_pattern(item, f"{where}[{i}]"):
                raise PatternError(f"{where}: cannot capture inside $in")
    if op == "$not" and check_pattern(arg, where):
        raise PatternError(f"{where}: cannot capture inside $not")
    if op in ("$contains", "$match"):
        found = check_pattern(arg, where)
        if op == "$contains" and found:
            raise PatternError(f"{where}: cannot capture inside $contains")
        return found
    return []


def match(pattern: Any, value: Any, captures: dict[str, Any] | None = None) -> str | None:
    """``None`` when ``value`` matches ``pattern``, else a one-line reason for the first mismatch.

    Captured values are written to ``captures`` only when the whole value matches.
    """
    found: dict[str, Any] = {}
    reason = _match(pattern, value, "$", found)
    if reason is None and captures is not None:
        captures.update(found)
    return reason


def _short(value: Any, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _match(pattern: Any, value: Any, path: str, found: dict[str, Any]) -> str | None:
    if is_operator(pattern):
        for op, arg in pattern.items():
            reason = _apply(op, arg, value, path, found)
            if reason is not None:
                return reason
        return None
    if isinstance(pattern, dict):
        if not isinstance(value, dict):
            return f"{path}: expected an object, got {_short(value)}"
        for key, sub in pattern.items():
            at = f"{path}.{key}"
            if is_operator(sub) and "$absent" in sub:
                if key in value:
                    return f"{at}: must be absent, got {_short(value[key])}"
                continue
            if key not in value:
                return f"{at}: missing"
            reason = _match(sub, value[key], at, found)
            if reason is not None:
                return reason
        return None
    if isinstance(pattern, list):
        if not isinstance(value, list):
            return f"{path}: expected a list, got {_short(value)}"
        if len(pattern) != len(value):
            return f"{path}: expected {len(pattern)} items, got {len(value)}: {_short(value)}"
        for i, (sub, item) in enumerate(zip(pattern, value, strict=True)):
            reason = _match(sub, item, f"{path}[{i}]", found)
            if reason is not None:
                return reason
        return None
    if _scalar_equal(pattern, value):
        return None
    return f"{path}: expected {_short(pattern)}, got {_short(value)}"


def _scalar_equal(pattern: Any, value: Any) -> bool:
    """JSON equality: numbers compare by value, but ``true`` is never ``1``."""
    if isinstance(pattern, bool) or isinstance(value, bool):
        return type(pattern) is type(value) and pattern == value
    if _is_number(pattern):
        return _is_number(value) and pattern == value
    if pattern is None:
        return value is None
    return isinstance(value, str) and pattern == value


def _apply(op: str, arg: Any, value: Any, path: str, found: dict[str, Any]) -> str | None:
    """Check one operator; ``None`` when it holds."""
    kind = json_type(value)
    if op == "$any":
        return None
    if op == "$absent":
        return f"{path}: must be absent, got {_short(value)}"
    if op == "$type":
        ok = kind == arg or (arg == "number" and kind == "integer")
        return None if ok else f"{path}: expected type {arg}, got {kind} {_short(value)}"
    if op == "$regex":
        if isinstance(value, str) and re.search(arg, value):
            return None
        return f"{path}: expected text matching /{arg}/, got {_short(value)}"
    if op == "$contains":
        return _contains(arg, value, path)
    if op == "$len":
        if kind in ("string", "array", "object", "bytes") and len(value) == arg:
            return None
        size = len(value) if kind in ("string", "array", "object", "bytes") else "no"
        return f"{path}: expected length {arg}, got {size} length: {_short(value)}"
    if op == "$in":
        if any(_match(option, value, path, {}) is None for option in arg):
            return None
        return f"{path}: {_short(value)} matches none of {_short(arg)}"
    if op == "$not":
        if _match(arg, value, path, {}) is None:
            return f"{path}: {_short(value)} must not match {_short(arg)}"
        return None
    if op in ("$gt", "$lt"):
        if not _is_number(value):
            return f"{path}: expected a number, got {_short(value)}"
        ok = value > arg if op == "$gt" else value < arg
        word = "greater" if op == "$gt" else "less"
        return None if ok else f"{path}: expected a number {word} than {arg}, got {value}"
    if op == "$tag":
        tag = getattr(value, "cbor_tag", None)
        return None if tag == arg else f"{path}: expected CBOR typed-array tag {arg}, got {tag}"
    if op == "$match":
        return _match(arg, value, path, found)
    found[arg] = value  # $capture
    return None


def _contains(arg: Any, value: Any, path: str) -> str | None:
    if isinstance(value, str):
        if isinstance(arg, str) and arg in value:
            return None
        return f"{path}: expected text containing {_short(arg)}, got {_short(value)}"
    if isinstance(value, list):
        if any(_match(arg, item, path, {}) is None for item in value):
            return None
        return f"{path}: no item matches {_short(arg)} in {_short(value, 160)}"
    return f"{path}: $contains needs a string or a list, got {_short(value)}"

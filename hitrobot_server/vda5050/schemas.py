"""The VDA 5050 2.0.0 JSON schemas (kept as published in ``protocol/vda5050/``), compiled once
into validators; a message's first problem worded with the path of the field."""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

VERSION = "2.0.0"
MAJOR = "v2"
FILES = {
    "order": "order.schema", "instantActions": "instantActions.schema",
    "state": "state.schema", "connection": "connection.schema",
    "factsheet": "factsheet.schema", "visualization": "visualization.schema",
}


def schema_dir() -> Path:
    """The checkout's ``protocol/vda5050``, else the copy an installed wheel ships."""
    package = Path(__file__).resolve().parents[1]
    repo = package.parent / "protocol" / "vda5050"
    return repo if repo.is_dir() else package / "_protocol" / "vda5050"


def load(topic: str) -> dict:
    return json.loads((schema_dir() / FILES[topic]).read_text(encoding="utf-8"))


@functools.cache
def validator(topic: str) -> Any:
    """The compiled validator of ``topic`` (jsonschema, draft 2020-12)."""
    from jsonschema import Draft202012Validator

    schema = load(topic)
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


def problem(topic: str, message: Any) -> str | None:
    """Why ``message`` fails ``topic``'s schema (the first failure, its field named), or None."""
    error = next(iter(validator(topic).iter_errors(message)), None)
    if error is None:
        return None
    where = ".".join(str(p) for p in error.absolute_path) or "the message"
    text = error.message if len(error.message) <= 200 else error.message[:200] + "..."
    return f"{where}: {text}"

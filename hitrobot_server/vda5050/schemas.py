"""The VDA 5050 2.0.0 JSON schemas (kept as published in ``protocol/vda5050/``), compiled once
into validators; a message's first problem worded with the path of the field."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
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
def validator(topic: str) -> Callable[[Any], Any]:
    """The compiled validator of ``topic`` (fastjsonschema: Python code made once from the
    schema; a full order of 1,000 nodes is checked in milliseconds, on the event loop)."""
    import fastjsonschema

    return fastjsonschema.compile(load(topic))


def problem(topic: str, message: Any) -> str | None:
    """Why ``message`` fails ``topic``'s schema (the first failure, its field named), or None."""
    import fastjsonschema

    try:
        validator(topic)(message)
    except fastjsonschema.JsonSchemaValueException as exc:
        text = exc.message.removeprefix("data.").replace("data ", "the message ", 1)
        return text if len(text) <= 200 else text[:200] + "..."
    return None

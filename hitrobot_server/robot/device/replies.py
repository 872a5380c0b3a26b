"""The sim-device's answers, worded as the robot words them, and the request bodies it reads."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

import orjson
from aiohttp import web

from ..rest import shapes

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


def reply(value: Any, status: int = 200) -> web.Response:
    """A JSON answer; bare booleans and numbers are sent bare, as the robot does."""
    return web.Response(body=orjson.dumps(value), status=status,
                        content_type="application/json")


def text(status: int, message: str) -> web.Response:
    return web.Response(text=message, status=status)


def empty() -> web.Response:
    return web.Response(status=200)


async def body_of(request: web.Request) -> Any:
    raw = await request.read()
    if not raw.strip():
        raise shapes.ShapeError("a JSON body is required")
    return orjson.loads(raw)


def getter(fetch: Callable[[], Awaitable[Any]], encode: Callable[[Any], Any]) -> Handler:
    """A ``GET`` answering ``encode(await fetch())``."""
    async def handle(request: web.Request) -> web.Response:
        return reply(encode(await fetch()))

    return handle


def enabler(apply: Callable[[bool], Awaitable[None]]) -> Handler:
    """A ``PUT`` of ``{"enable": bool}`` handed to ``apply``."""
    async def handle(request: web.Request) -> web.Response:
        body = shapes.obj(await body_of(request), "body")
        await apply(shapes.boolean(body.get("enable"), "enable"))
        return reply(True)

    return handle

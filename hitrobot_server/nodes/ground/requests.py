"""Carrying out a request published on a topic, and what its publisher is told.

Robot nodes take requests on topics and answer through the message's :class:`Reply` once the
robot has answered them; this is the one place that turns robot errors into those answers, so
every node words "the robot is not connected" (and the rest) the same way.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable

from ...bus.requests import Reply
from ...bus.topics import RequestRejected
from ...robot.backend import BackendError, Link, NotConnectedError

log = logging.getLogger(__name__)

NOT_CONNECTED = "the robot is not connected"


def labelled(what: str, text: str) -> str:
    """``what: text``, or ``text`` alone for a request that names no operation."""
    return f"{what}: {text}" if what else text


def robot_error(exc: Exception, failed: str = "") -> str:
    """The text of a robot failure: one plain wording for an offline robot; any other keeps
    its own text, after ``failed`` when given (``robot pose unavailable: …``)."""
    return NOT_CONNECTED if isinstance(exc, NotConnectedError) else labelled(failed, str(exc))


def require_robot(link: Link, what: str) -> None:
    """Refuse ``what`` at once while the robot is offline; the publisher hears why."""
    if not link.connected:
        raise RequestRejected(labelled(what, NOT_CONNECTED))


async def answer(reply: Reply, what: str, work: Awaitable[str | None], *,
                 known: tuple[type[Exception], ...] = (), failed: str | None = None) -> None:
    """Await ``work`` and answer the publisher: the text it returns as ok (nothing when it
    returns none, e.g. when it answered itself); an offline robot as ``what: the robot is not
    connected``; another robot error, or one of the ``known`` request errors, with its text
    after ``what`` (after ``failed`` when given); anything else is logged and reported after
    ``what failed`` (or ``failed``).
    """
    try:
        text = await work
    except NotConnectedError:
        reply.fail(labelled(what, NOT_CONNECTED))
    except (BackendError, *known) as exc:
        reply.fail(robot_error(exc, what if failed is None else failed))
    except Exception as exc:
        label = failed or f"{what} failed"
        log.exception("%s", label)
        reply.fail(labelled(label, str(exc)))
    else:
        if text:
            reply.ok(labelled(what, text))

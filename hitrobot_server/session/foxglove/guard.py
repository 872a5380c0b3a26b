"""The role check of every Foxglove op, in one place: what an op asks (kind, name, message) for
:meth:`~..access.Access.check`, before the op acts. An op naming several things is refused
whole when one of them is (nothing of it is done)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, Protocol

from ...bus.cdr import Ros2Codec
from ...bus.topics import Origin
from ...protocol import foxglove as fg
from .channels import ChannelOps
from .frames import decode_cdr
from .publish import PublishOps
from .shared import FoxgloveShared


class Guarded(Protocol):
    """What the check reads of a Foxglove session: who it is, and what its ids name."""

    shared: FoxgloveShared
    origin: Origin
    codec: Ros2Codec
    channels: dict[int, str]
    channel_ops: ChannelOps
    publishing: PublishOps

PLAYBACK = "/playback"  # the name a playbackControl is checked under


def refusal(session: Guarded, item: Any) -> str | None:
    """None when the client may do ``item`` (a parsed op, a binary message or call, or
    ``PLAYBACK``); else why not (an error status naming the role and the permission)."""
    access = session.shared.access
    if not access.enabled:
        return None
    for kind, name, message in _asked(session, item):
        reason = access.check(session.origin, kind, name, message)
        if reason is not None:
            return reason
    return None


def _asked(session: Guarded, item: Any) -> Iterator[tuple[str, str, Any]]:
    match item:
        case fg.Subscribe():
            for _sid, cid in item.subscriptions:
                yield "subscribe", session.channels.get(cid, f"channel {cid}"), None
        case fg.Advertise():
            for chan in item.channels:
                yield "publish", chan.topic, None
        case fg.ClientMessage():
            chan = session.publishing.client_channels.get(item.channel_id)
            if chan is not None:
                yield "publish", chan.topic, _message(session, chan, item.payload)
        case fg.ServiceCallRequest():
            entry = session.channel_ops.services.get(item.service_id)
            if entry is not None:
                yield "call", entry[0], _request(session, entry[1], item.payload)
        case fg.GetParameters() | fg.SubscribeParameterUpdates():
            for name in item.parameter_names or ("/",):
                yield "param_get", name, None
        case fg.SetParameters():
            for name, _value in item.parameters:
                yield "param_set", name, None
        case str() if item == PLAYBACK:
            yield "playback", PLAYBACK, None


def _request(session: Guarded, stype: Any, payload: bytes) -> Any:
    """A call's decoded request, only for a role with limits (a goal's pose)."""
    if session.shared.access.role_of(session.origin).limits is None:
        return None
    try:
        return decode_cdr(session.codec, payload, stype.request)
    except Exception:
        return None  # unreadable: a goal without a pose, refused


def _message(session: Guarded, chan: Any, payload: bytes) -> Any:
    """The decoded message, only for a role whose limits read it (an agent's speed or goal);
    undecodable is None here (the publish itself reports it)."""
    if session.shared.access.role_of(session.origin).limits is None:
        return None
    try:
        return decode_cdr(session.codec, payload, chan.mtype)
    except Exception:
        return {"linear": {"x": float("inf")}}  # unreadable: refused as over any limit

"""This process's one Zenoh session, as the link's parts share it: the hop from Zenoh's threads
onto the event loop, this process's liveliness tokens, sample attachments and queries."""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import itertools
import logging
import time
from typing import Any

import zenoh

from ..cdr import codec_for
from ..core import Bus
from ..errors import ServiceError
from ..link import PARAM_SERVICES
from ..topics import Origin
from .keys import NODE, data_key, pack_attachment, token

log = logging.getLogger(__name__)

ACTION_SUFFIX = "/_action/send_goal"
LOCAL_ONLY = ("/rosapi/",)  # every server has its own rosapi
RESULT_WAIT = 24 * 3600.0  # a get_result query waits for the goal to finish
REMOTE = Origin("/zenoh")  # the origin of every message that came from another process
REMOTE_OWNER = object()  # the owner of every proxy of another process's service or action


class Peer:
    """One Zenoh session joined to ``bus``; opened by :meth:`open`, closed by :meth:`close`."""

    def __init__(self, bus: Bus, domain: int, config: zenoh.Config, shared_params: bool):
        self.bus = bus
        self.codec = codec_for(bus.types)
        self.domain = domain
        self.shared_params = shared_params
        self._config = config
        self.session: zenoh.Session | None = None
        self.zid = ""
        self.loop: asyncio.AbstractEventLoop | None = None
        self._nids: dict[str, int] = {}
        self._eids = itertools.count(1)
        self._seq = itertools.count(1)
        self._tokens: dict[tuple[str, str, str], Any] = {}  # (kind, name, node) -> token

    async def open(self) -> None:
        self.loop = asyncio.get_running_loop()
        try:
            self.session = await asyncio.to_thread(zenoh.open, self._config)
        except zenoh.ZError as exc:
            raise OSError(f"zenoh: cannot open a session: {exc}") from None
        self.zid = str(self.session.zid())

    async def close(self) -> None:
        session, self.session = self.session, None
        if session is not None:
            await asyncio.to_thread(session.close)

    def hop(self, fn, *args) -> None:
        """Run ``fn(*args)`` on the event loop (called from Zenoh's threads)."""
        loop = self.loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(fn, *args)

    def key(self, name: str, type_name: str, type_hash: str) -> str:
        """The data key of ``name`` in this link's domain."""
        return data_key(self.domain, name, type_name, type_hash)

    def gid(self, *parts: str) -> bytes:
        return hashlib.blake2b("/".join((self.zid, *parts)).encode(), digest_size=16).digest()

    def attachment(self, gid: bytes) -> bytes:
        """The next sample or query attachment: sequence number, now, ``gid``."""
        return pack_attachment(next(self._seq), time.time_ns(), gid)

    def local_only(self, name: str) -> bool:
        """Names that never cross: rosapi, except the parameters when they are shared (the
        workers of one ``--workers`` server: the process serving them keeps the only store)."""
        if self.shared_params and name in PARAM_SERVICES:
            return False
        return name.startswith(LOCAL_ONLY)

    # ------------------------------------------------------------------ liveliness tokens
    def _declare_token(self, kind: str, name: str, node: str, **endpoint: str) -> None:
        key = (kind, name, node)
        if key in self._tokens or self.session is None:
            return
        nid = self._nids.setdefault(node, len(self._nids))
        eid = nid if kind == NODE else next(self._eids) + 10_000
        expr = token(self.domain, self.zid, nid, eid, kind, node, name, **endpoint)
        try:
            self._tokens[key] = self.session.liveliness().declare_token(expr)
        except zenoh.ZError as exc:
            log.warning("zenoh: cannot announce %s %s: %s", kind, name, exc)

    def sync_tokens(self, kind: str, name: str, nodes: set[str], **endpoint: str) -> None:
        """Announce ``kind`` ``name`` for exactly ``nodes`` (withdraw the others' tokens)."""
        for key in [k for k in self._tokens if k[0] == kind and k[1] == name]:
            if key[2] not in nodes:
                with contextlib.suppress(zenoh.ZError):
                    self._tokens.pop(key).undeclare()
        for node in nodes:
            self._declare_token(kind, name, node, **endpoint)

    # ------------------------------------------------------------------ queries
    async def get(self, key: str, payload: bytes, timeout: float | None, what: str) -> bytes:
        """One query to the (single) provider; ServiceError with the reason on failure."""
        assert self.loop is not None and self.session is not None
        done: asyncio.Future[bytes] = self.loop.create_future()

        def settle(ok: bytes | None, err: str | None) -> None:
            if done.done():
                return
            if ok is not None:
                done.set_result(ok)
            else:
                done.set_exception(ServiceError(err or f"{what}: no answer"))

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                self.hop(settle, reply.ok.payload.to_bytes(), None)
            else:
                self.hop(settle, None, reply.err.payload.to_string())

        def on_end() -> None:
            self.hop(settle, None, f"{what}: no answer (its server is gone or too slow)")

        self.session.get(
            key,
            zenoh.handlers.Callback(on_reply, on_end),
            payload=payload,
            attachment=self.attachment(self.gid("client", key)),
            target=zenoh.QueryTarget.BEST_MATCHING,
            timeout=timeout if timeout and timeout > 0 else RESULT_WAIT,
        )
        return await done

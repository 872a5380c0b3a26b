"""A site-wide role over Zenoh (:class:`~hitrobot_server.bus.link.Group`): one process leads,
the others follow, and a follower takes over when the leader's liveliness goes.

Liveliness tokens (outside rmw_zenoh's ``@ros2_lv`` space, so rosapi never lists them):
``@hitrobot/<domain>/<group>/member/<zid>`` for every process taking part and
``@hitrobot/<domain>/<group>/leader/<claimed>/<zid>`` for the one leading (``claimed``: when it
claimed, in ns since the epoch). Election: a live leader is kept (a process joining later
never takes its place); with none, the live member with the smallest id claims, once it has
waited :data:`CLAIM_WAIT` s for the others' tokens. Two leaders that did not see each other when
they claimed (a link that came up late) settle on the earlier claim; the other steps down. A
process killed loses its tokens when its peers' links to it close, so its followers elect
again at once.

Queries: the leader's changes go to ``hitrobot/<domain>/<group>/replica/*`` (each follower's
queryable applies one and answers; the leader's id rides as the query's attachment, and a
follower refuses a change from any process but the one it follows); a follower that joins or
missed a change asks ``…/snapshot/<leader zid>`` for the whole state.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from typing import Any

import zenoh

from ..errors import ServiceError
from ..link import GroupMember
from .peer import Peer

log = logging.getLogger(__name__)

SURVEY_TIMEOUT = 3.0
"""Seconds the first look at the group's tokens may take (it ends when every peer answered)."""
CLAIM_WAIT = 1.0
"""Seconds a process that sees no other member waits for their tokens before it claims (its
links to the other servers may still be coming up)."""


class ZenohGroup:
    """Implements :class:`~hitrobot_server.bus.link.Group` on the link's Zenoh session."""

    def __init__(self, peer: Peer, name: str):
        self.peer = peer
        self.name = name
        self.me = ""
        self.tokens = f"@hitrobot/{peer.domain}/{name}"
        self.data = f"hitrobot/{peer.domain}/{name}"
        self.members: set[str] = set()
        self.leaders: dict[str, int] = {}  # zid -> when it claimed
        self.leader = ""
        self._claimed = 0
        self._heard = asyncio.Event()  # a token of another process came or went
        self._joined = False  # the first look is over: every change decides again
        self._member: GroupMember | None = None
        self._held: list[Any] = []  # member token, replica queryable, liveliness subscriber
        self._leading: list[Any] = []  # leader token and snapshot queryable, while leading

    # ------------------------------------------------------------------ membership
    async def join(self, member: GroupMember) -> None:
        session = self.peer.session
        assert session is not None and self.peer.loop is not None
        self._member, self.me = member, self.peer.zid
        self._held = [
            session.declare_queryable(f"{self.data}/replica/{self.me}", self._on_replica),
            session.liveliness().declare_token(f"{self.tokens}/member/{self.me}"),
            session.liveliness().declare_subscriber(f"{self.tokens}/**", self._on_token,
                                                    history=True),
        ]
        self.members.add(self.me)
        await self._survey()
        if self.members == {self.me}:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._heard.wait(), CLAIM_WAIT)
            await self._survey()
        if self._member is None:  # left meanwhile
            return
        self._joined = True
        self._decide()

    async def _survey(self) -> None:
        """The group's tokens as they are now (the query ends when every peer answered)."""
        session, loop = self.peer.session, self.peer.loop
        assert session is not None and loop is not None
        surveyed = loop.create_future()

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                self.peer.hop(self._token, str(reply.ok.key_expr), True)

        def on_end() -> None:
            self.peer.hop(lambda: surveyed.done() or surveyed.set_result(None))

        session.liveliness().get(f"{self.tokens}/**",
                                 zenoh.handlers.Callback(on_reply, on_end),
                                 timeout=SURVEY_TIMEOUT)
        await surveyed

    async def leave(self) -> None:
        self._step_down()
        for held in self._held:
            with contextlib.suppress(zenoh.ZError):
                held.undeclare()
        self._held, self._member, self._joined = [], None, False

    def _on_token(self, sample: zenoh.Sample) -> None:
        self.peer.hop(self._token, str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

    def _token(self, key: str, alive: bool) -> None:
        kind, _, rest = key.removeprefix(f"{self.tokens}/").partition("/")
        claimed, _, zid = rest.rpartition("/")
        if not zid or zid == self.me or self._member is None:
            return
        if kind == "member" and alive != (zid in self.members):
            (self.members.add if alive else self.members.discard)(zid)
        elif kind == "leader" and claimed.isdigit() and alive != (zid in self.leaders):
            if alive:
                self.leaders[zid] = int(claimed)
            else:
                self.leaders.pop(zid)
        else:
            return
        self._heard.set()
        if self._joined:
            self._decide()

    def _decide(self) -> None:
        """Follow a live leader; with none, the smallest live member claims."""
        first = min(((c, z) for z, c in self.leaders.items()), default=None)
        leading = bool(self._leading)
        if first is not None and not (leading and (self._claimed, self.me) < first):
            self._step_down()
            self._set_leader(first[1])
        elif leading:
            self._set_leader(self.me)
        elif self.me == min(self.members):
            self._claim()
        else:
            self._set_leader("")

    def _claim(self) -> None:
        session = self.peer.session
        assert session is not None
        self._claimed = time.time_ns()
        # the snapshot's queryable before the token: whoever sees the token can fetch
        self._leading = [
            session.declare_queryable(f"{self.data}/snapshot/{self.me}", self._on_snapshot),
            session.liveliness().declare_token(
                f"{self.tokens}/leader/{self._claimed}/{self.me}"),
        ]
        log.info("zenoh: %s leads the group '%s'", self.me[:8], self.name)
        self._set_leader(self.me)

    def _step_down(self) -> None:
        for held in reversed(self._leading):
            with contextlib.suppress(zenoh.ZError):
                held.undeclare()
        self._leading = []

    def _set_leader(self, leader: str) -> None:
        if leader != self.leader:
            self.leader = leader
            if self._member is not None:
                self._member.role(leader)

    # ------------------------------------------------------------------ changes
    async def replicate(self, payload: bytes, timeout: float) -> tuple[int, int]:
        followers = len(self.members - {self.me})
        session, loop = self.peer.session, self.peer.loop
        if not followers or session is None or loop is None or self.leader != self.me:
            return 0, followers
        acks = [0]
        done = loop.create_future()

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                self.peer.hop(acks.__setitem__, 0, acks[0] + 1)

        def on_end() -> None:
            self.peer.hop(lambda: done.done() or done.set_result(None))

        session.get(f"{self.data}/replica/*", zenoh.handlers.Callback(on_reply, on_end),
                    payload=payload, attachment=self.me.encode(),
                    target=zenoh.QueryTarget.ALL,
                    consolidation=zenoh.ConsolidationMode.NONE,
                    allowed_destination=zenoh.Locality.REMOTE, timeout=timeout)
        await done
        return acks[0], followers

    async def fetch(self, timeout: float) -> bytes:
        leader = self.leader
        if not leader or leader == self.me:
            raise ServiceError("no other process leads")
        return await self.peer.get(f"{self.data}/snapshot/{leader}", b"", timeout,
                                   f"the {self.name} leader's state")

    def _on_replica(self, query: zenoh.Query) -> None:
        sender = query.attachment.to_bytes().decode() if query.attachment is not None else ""
        payload = query.payload.to_bytes() if query.payload is not None else b""
        self.peer.hop(self._spawn_replica, query, sender, payload)

    def _spawn_replica(self, query: zenoh.Query, sender: str, payload: bytes) -> None:
        asyncio.ensure_future(self._apply(query, sender, payload))

    async def _apply(self, query: zenoh.Query, sender: str, payload: bytes) -> None:
        try:
            if self._member is None or sender != self.leader or sender == self.me:
                query.reply_err(f"{self.me[:8]} does not follow {sender[:8]}")
                return
            await self._member.apply(payload)
            query.reply(f"{self.data}/replica/{self.me}", b"ok")
        except Exception as exc:  # a change this follower could not keep: the leader counts it
            log.warning("zenoh: group '%s': a change was not applied: %s", self.name, exc)
            with contextlib.suppress(zenoh.ZError):
                query.reply_err(str(exc))
        finally:
            query.drop()

    def _on_snapshot(self, query: zenoh.Query) -> None:
        self.peer.hop(self._answer_snapshot, query)

    def _answer_snapshot(self, query: zenoh.Query) -> None:
        try:
            if self._member is None or not self._leading:
                query.reply_err("not the leader")
            else:
                query.reply(f"{self.data}/snapshot/{self.me}", self._member.snapshot())
        finally:
            query.drop()

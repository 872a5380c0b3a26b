"""Incoming ``fragment`` ops of one rosbridge client, reassembled, and evicted on time."""

from __future__ import annotations

import asyncio
import time
from dataclasses import asdict
from typing import Protocol

from ...protocol.fragment import Defragmenter, FragmentBudget
from ...protocol.ops import Fragment
from ..options import SessionOptions


class FragmentOwner(Protocol):
    closed: bool

    def status(self, level: str, msg: str, op_id: object = None) -> None: ...


class IncomingFragments:
    """The client's messages being reassembled, within the server-wide byte budget."""

    def __init__(self, client: FragmentOwner, settings: SessionOptions, budget: FragmentBudget):
        self.client = client
        self._defrag = Defragmenter(
            fragment_timeout=settings.fragment_timeout,
            max_bytes=settings.max_frame_size,
            budget=budget,
        )
        self._timer: asyncio.TimerHandle | None = None

    def add(self, op: Fragment) -> str | None:
        """The whole message's text once its last fragment came, else None."""
        try:
            return self._defrag.add(asdict(op), time.monotonic())
        finally:
            self._arm()

    def _arm(self) -> None:
        """Evict timed-out fragments on time, not when the next fragment happens to come."""
        due = self._defrag.next_expiry()
        if due is None or self._timer is not None or self.client.closed:
            return
        delay = max(due - time.monotonic(), 0.0)
        self._timer = asyncio.get_running_loop().call_later(delay, self._expire)

    def _expire(self) -> None:
        self._timer = None
        for key in self._defrag.expire(time.monotonic()):
            self.client.status(
                "warning",
                f"fragment: message '{key}' got no fragment for {self._defrag.fragment_timeout:g}"
                " s (--fragment-timeout) and was dropped",
                key,
            )
        self._arm()

    def close(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
        self._defrag.clear()  # its bytes go back to the server-wide budget now

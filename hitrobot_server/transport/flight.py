"""A window of bytes in flight per client: sent by the server, not yet read by the client.

The fair outbox chooses what goes next only among the frames still inside the server. Bytes
already handed to the kernel, sitting in the client's receive buffer or in a Wi-Fi access
point's queue are beyond its reach: a pose sent behind two megabytes of point cloud arrives a
second late to a 2 MB/s reader, however fair the outbox was. So a transport that can learn how
far its client has read (WebSocket: a ping, which every client answers once it has read up to
it, RFC 6455 §5.5.2) keeps what is unread under a window, and what does not fit waits in the
outbox, where the scheduler still picks among it.

The window is sized from what the pongs show (sans-I/O: the transport reports bytes sent,
pings and pongs with their times): the client's delivery rate (the best rate seen over the last
second, each sample over at least :data:`RATE_SPAN` seconds of pongs) times the lowest round
trip seen plus :data:`TARGET` seconds of queue. A link that keeps up (a round trip well under
the target with the window full) doubles the window; a slow reader's window shrinks to about
:data:`TARGET` seconds of what it reads. Between :data:`MIN_WINDOW` and :data:`MAX_WINDOW`.

On top of the window, a client that showed no standing queue lately (a quick pong within the
last :data:`QUICK_SPAN` seconds) may have up to :data:`BURST` seconds of its rate unread
(:meth:`room`): a fast reader that reads in bursts, or whose process waits for a busy CPU, has a
late pong now and then but quick ones in between, and keeps its rate through its pauses. A slow
reader's pongs are all late once its queue has built up: it gets the window alone. A client that
answers no ping for :data:`GIVE_UP` seconds (a client library that never pongs) is not held at
all until its next pong: it gets what a client without the window gets (the kernel's short
unsent queue, the fair outbox).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

TARGET = 0.03
"""Seconds of delivery the unread bytes may stand for beyond the bare round trip."""
MIN_WINDOW = 48 * 1024
MAX_WINDOW = 16 * 1024 * 1024
INITIAL_WINDOW = 256 * 1024
MIN_PING_EVERY = 16 * 1024
GAIN = 2
"""The window is this many times the delivery rate's worth of (round trip + target): room for
a link that the window held back to show a higher rate (a slow reader's rate stays put)."""
RATE_SPAN = 0.02
"""A rate sample spans at least this long (pongs that arrive in one read are one sample)."""
RATE_MEMORY = 1.0
"""Seconds a rate sample counts toward the estimate (the link may have become slower since)."""
PROBE_EVERY = 0.1
"""After an idle spell, a ping goes with the first bytes (a round trip with no queue before it)
at most this often."""
BURST = 0.25
"""Seconds of its delivery rate a client with no standing queue may have unread."""
QUICK_SPAN = 0.25
"""A pong this recent under the bare round trip plus the target: no standing queue."""
GIVE_UP = 5.0
"""Seconds a ping may go unanswered before the window stops holding the client back."""
FIRST_GIVE_UP = 1.0
"""The same for a client that never answered one (a client library that does not pong loses
a second at most, once)."""


@dataclass(slots=True)
class _Ping:
    mark: int  # bytes sent when it went out: its pong says the client read that far
    at: float
    full: bool  # the window was (half) full: its pong tells what the link, not the sender, did
    clean: bool  # nothing was unread before the bytes it follows: a bare round trip


class FlightWindow:
    """Bytes in flight to one client and the window they must stay under (see module doc)."""

    def __init__(self, *, target: float = TARGET, min_window: int = MIN_WINDOW,
                 max_window: int = MAX_WINDOW, initial: int = INITIAL_WINDOW):
        self.target = target
        self.min_window = min_window
        self.max_window = max_window
        self.window = max(min_window, min(initial, max_window))
        self.sent = 0  # bytes sent, all told
        self.acked = 0  # bytes the client has confirmed reading
        self._unpinged = 0  # bytes sent since the last ping
        self._idle_before = True  # nothing was in flight when the current bytes began
        self._last_probe = -math.inf
        self._pings: deque[_Ping] = deque()
        self._pongs: deque[tuple[float, int]] = deque()  # (time, acked) of recent pongs
        self._rates: deque[tuple[float, float]] = deque()  # (time, bytes/s) samples
        self.base_rtt = math.inf  # the lowest bare round trip seen
        self._quick_at = -math.inf  # when a pong last came back within base rtt + target

    @property
    def in_flight(self) -> int:
        return self.sent - self.acked

    @property
    def open(self) -> bool:
        """Room for more: what the client has not read is under the window."""
        return self.in_flight < self.window

    def room(self, now: float) -> bool:
        """Room for more under the window, or under the burst allowance of a client with no
        standing queue (see module doc), or a silent client's (:meth:`silent`)."""
        if self.in_flight < self.window:
            return True
        if now - self._quick_at < QUICK_SPAN and self.in_flight < self.rate * BURST:
            return True
        return self.silent(now)

    def silent(self, now: float) -> bool:
        """The oldest ping out has gone unanswered for :data:`GIVE_UP` seconds
        (:data:`FIRST_GIVE_UP` before any pong): a client that does not pong, which the window
        stops holding back until its next pong."""
        limit = GIVE_UP if self.acked else FIRST_GIVE_UP
        return bool(self._pings) and now - self._pings[0].at >= limit

    @property
    def rate(self) -> float:
        """The client's delivery rate (bytes/s) as the pongs show it; 0 before any sample."""
        return max((r for _, r in self._rates), default=0.0)

    def on_sent(self, nbytes: int, now: float) -> bool:
        """``nbytes`` went out; True when a ping should follow them now."""
        if nbytes <= 0:
            return False
        if self.in_flight == 0:
            self._idle_before = True
        self.sent += nbytes
        self._unpinged += nbytes
        if self._idle_before and now - self._last_probe >= PROBE_EVERY:
            return True
        # every quarter window; and when full unless the pings out will reopen it
        return self._unpinged >= max(MIN_PING_EVERY, self.window // 4) or self.stuck

    @property
    def stuck(self) -> bool:
        """Full, and no ping out whose pong would bring what is unread under the window: a
        ping must go now (after the last bytes) or nothing reopens it."""
        return not self.open and self._unpinged > 0 and (
            not self._pings or self._unpinged >= self.window // 2)

    def pinged(self, now: float) -> int:
        """A ping went out after everything sent so far; returns its mark for :meth:`ponged`."""
        clean = self._idle_before and now - self._last_probe >= PROBE_EVERY
        if clean:
            self._last_probe = now
        self._idle_before = False
        self._unpinged = 0
        self._pings.append(_Ping(self.sent, now, self.in_flight >= self.window // 2, clean))
        return self.sent

    def ponged(self, mark: int, now: float) -> None:
        """The pong of the ping with ``mark`` came back: the client has read up to it (and up
        to every earlier ping). Updates the rate and the window."""
        while self._pings and self._pings[0].mark <= mark:
            ping = self._pings.popleft()
            if ping.mark <= self.acked:
                continue
            self.acked = ping.mark
            self._sample_rate(now)
            rtt = now - ping.at
            if ping.clean:
                self.base_rtt = min(self.base_rtt, rtt)
            if rtt < (self.base_rtt if math.isfinite(self.base_rtt) else 0.0) + self.target:
                self._quick_at = now
            self._resize(rtt, ping.full, drained=self.in_flight <= self.window // 4)

    def _sample_rate(self, now: float) -> None:
        pongs = self._pongs
        pongs.append((now, self.acked))
        while len(pongs) > 2 and now - pongs[1][0] > RATE_MEMORY:
            pongs.popleft()
        since = None
        for at, acked in reversed(pongs):
            if now - at >= RATE_SPAN:
                since = (at, acked)
                break
        if since is not None:
            self._rates.append((now, (self.acked - since[1]) / (now - since[0])))
        while self._rates and now - self._rates[0][0] > RATE_MEMORY:
            self._rates.popleft()

    def _resize(self, rtt: float, was_full: bool, drained: bool) -> None:
        window = self.window
        base = self.base_rtt if math.isfinite(self.base_rtt) else 0.0
        if self.rate > 0:  # twice the bytes the link carries in a round trip plus the target:
            # a window-limited link's rate grows with its window, a slow reader's does not. A
            # rate seen while the sender had little to send (the window not full) says nothing
            # of the link: it may raise the window, never lower it.
            sized = int(GAIN * self.rate * (base + self.target))
            if was_full or sized > window:
                window = sized
        if was_full and (rtt < base + self.target / 2 or (drained and rtt < base + self.target)):
            # the link kept up (a quick pong, or a client that read all it was sent within the
            # target, as a busy client does in bursts): the window held it back
            window = max(window, 2 * self.window)
        self.window = max(self.min_window, min(window, self.max_window))

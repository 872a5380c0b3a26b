"""A window of bytes in flight per client: sent by the server, not yet read by the client.

The fair outbox chooses what goes next only among the frames still inside the server. Bytes
already handed to the kernel, sitting in the client's receive buffer or in a Wi-Fi access
point's queue are beyond its reach: a pose sent behind two megabytes of point cloud arrives a
second late to a 2 MB/s reader, however fair the outbox was. So a transport that can learn how
far its client has read (WebSocket: a ping, which every client answers once it has read up to
it, RFC 6455 §5.5.2) keeps what is unread under a window, and what does not fit waits in the
outbox, where the scheduler still picks among it.

Sans-I/O: the transport reports bytes sent, pings and pongs with their times, and how late its
own loop runs. A pong's round trip is how old the bytes before its ping were when the client
read them.

**When it holds.** A client is held (*armed*) once it shows a standing queue: every pong of
the last :data:`ARM_SPAN` seconds came back more than :data:`ARM_AGE` late (beyond the server
loop's own lateness), or a ping has waited longer than both for its pong. A slow link does
that about a second after it is flooded. A fast reader whose process is busy now and then (one
process reading fifty sockets, a page that also draws) has quick pongs in between, and a queue
under half a second is not held at all. So a flood reaches such a reader as it would without
the window: the deep buffers that cost the slow reader freshness give the bursty fast reader
its throughput. A held client is let go when every pong of :data:`DISARM_SPAN` seconds came
back within :data:`DISARM_AGE`, its window half empty.

**How big.** The client's delivery rate, averaged over the pongs of the last
:data:`RATE_SPAN` seconds, times the bare round trip plus the server loop's recent lateness (a
busy server gets to each client once a turn) plus :data:`TARGET` seconds of queue, between
:data:`MIN_WINDOW` and :data:`MAX_WINDOW`. A slow reader's rate is its link's however much it
is sent: its unread bytes settle at about :data:`TARGET` seconds of what it reads. A reader
that answers within less than that reads more than the window per target: its window grows with
each pong until it no longer binds. The average spans several of a bursty reader's reads (a
browser that reads 256 kB at once, then waits for the link to bring more), whose single reads
would show many times its rate.

A client that never answered a ping (a client library that does not pong) is never held: it
gets what a client without the window gets (the kernel's short unsent queue, the fair outbox).
A held client that stops answering is let out after :data:`GIVE_UP` seconds, until its next
pong.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

TARGET = 0.03
"""Seconds of delivery an armed client's unread bytes may stand for, beyond the bare round trip
and the server loop's lateness."""
MIN_WINDOW = 48 * 1024
MAX_WINDOW = 16 * 1024 * 1024
INITIAL_WINDOW = 256 * 1024
MIN_PING_EVERY = 16 * 1024
RATE_SPAN = 0.25
"""The delivery rate is the bytes read over at least this long (while there are fewer seconds
of pongs, over what there is, from :data:`FIRST_SPAN` on)."""
FIRST_SPAN = 0.02
ARM_AGE = 0.5
ARM_SPAN = 0.3
"""A client is held once all its pongs over ``ARM_SPAN`` s came back over ``ARM_AGE`` s late."""
DISARM_AGE = 0.01
DISARM_SPAN = 2.0
"""A held client is let go once all its pongs over ``DISARM_SPAN`` s came back within
``DISARM_AGE`` s (beyond the server loop's lateness) with under half its window unread: a held
slow reader's pongs are up to about twice :data:`TARGET` late and its window full, so it is not
let go now and then only to queue seconds again."""
WATCH_EVERY = 0.1
"""Seconds between the pings to a client not held: they watch for a standing queue at the cost
of ten pongs a second, where pinging every quarter window would cost a fast reader hundreds."""
PROBE_EVERY = 0.1
"""After an idle spell, a ping goes with the first bytes (a round trip with no queue before it)
at most this often."""
GIVE_UP = 5.0
"""Seconds a ping may go unanswered before the window stops holding the client back."""
FIRST_GIVE_UP = 1.0
"""The same for a client that never answered one (a client library that does not pong loses
a second at most, once)."""


@dataclass(slots=True)
class _Ping:
    mark: int  # bytes sent when it went out: its pong says the client read that far
    at: float
    clean: bool  # nothing was unread before the bytes it follows: a bare round trip


class FlightWindow:
    """Bytes in flight to one client and the window they must stay under (see module doc)."""

    def __init__(self, *, target: float = TARGET, min_window: int = MIN_WINDOW,
                 max_window: int = MAX_WINDOW, initial: int = INITIAL_WINDOW):
        self.target = target
        self.min_window = min_window
        self.max_window = max_window
        self.window = max(min_window, min(initial, max_window))
        self.armed = False  # the window holds this client (a standing queue was seen)
        self.sent = 0  # bytes sent, all told
        self.acked = 0  # bytes the client has confirmed reading
        self.rate = 0.0  # the client's delivery rate (bytes/s) as the pongs show it
        self.base_rtt = math.inf  # the lowest bare round trip seen
        self._unpinged = 0  # bytes sent since the last ping
        self._idle_before = True  # nothing was in flight when the current bytes began
        self._last_probe = -math.inf
        self._last_ping = -math.inf
        self._pings: deque[_Ping] = deque()
        self._pongs: deque[tuple[float, int]] = deque()  # (time, acked) for the rate
        self._lag = 0.0  # the server loop's lateness at the last pong
        self._late_since = math.inf  # since when every pong came back over ARM_AGE late
        self._quick_since = math.inf  # since when every pong came back within DISARM_AGE

    @property
    def in_flight(self) -> int:
        return self.sent - self.acked

    @property
    def open(self) -> bool:
        """Room for more: the client is not held, or what it has not read is under the
        window."""
        return not self.armed or self.in_flight < self.window

    def room(self, now: float) -> bool:
        """Room for more (:attr:`open`), or a silent client's (:meth:`silent`)."""
        return self.open or self.silent(now)

    def silent(self, now: float) -> bool:
        """The oldest ping out has gone unanswered for :data:`GIVE_UP` seconds
        (:data:`FIRST_GIVE_UP` before any pong): a client that does not pong, which the window
        stops holding back until its next pong."""
        limit = GIVE_UP if self.acked else FIRST_GIVE_UP
        return bool(self._pings) and now - self._pings[0].at >= limit

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
        if not self.armed:  # enough pongs to see a standing queue and the rate, no more
            if self.acked and self._pings and \
                    now - self._pings[0].at > ARM_AGE + ARM_SPAN + self._lag:
                self.armed = True  # a ping unanswered that long is a standing queue too
            return now - self._last_ping >= WATCH_EVERY
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
        self._last_ping = now
        self._pings.append(_Ping(self.sent, now, clean))
        return self.sent

    def ponged(self, mark: int, now: float, lag: float = 0.0) -> None:
        """The pong of the ping with ``mark`` came back: the client has read up to it (and up
        to every earlier ping). Updates the rate, whether the client is held, and the window.
        ``lag``: how late the server's own loop ran lately (its busiest turn)."""
        rtt = -1.0
        while self._pings and self._pings[0].mark <= mark:
            ping = self._pings.popleft()
            if ping.mark <= self.acked:
                continue
            self.acked = ping.mark
            rtt = now - ping.at
            if ping.clean:
                self.base_rtt = min(self.base_rtt, rtt)
        if rtt < 0:
            return
        self._lag = lag
        self._sample_rate(now)
        base = self.base_rtt if math.isfinite(self.base_rtt) else 0.0
        allowance = base + lag + self.target
        self._judge(rtt, now, lag)
        if self.rate > 0:
            self.window = max(self.min_window, min(int(self.rate * allowance), self.max_window))

    def _judge(self, rtt: float, now: float, lag: float) -> None:
        """Arm on a standing queue, let go of a client that keeps up (see module doc). A pong
        the server's own busy loop made late says nothing of the client."""
        if rtt > ARM_AGE + lag:
            self._late_since = min(self._late_since, now)
        else:
            self._late_since = math.inf
        if rtt < DISARM_AGE + lag and self.in_flight < self.window // 2:
            self._quick_since = min(self._quick_since, now)
        else:
            self._quick_since = math.inf
        if not self.armed and now - self._late_since >= ARM_SPAN:
            self.armed = True
            self._quick_since = math.inf
        elif self.armed and now - self._quick_since >= DISARM_SPAN:
            self.armed = False

    def _sample_rate(self, now: float) -> None:
        """The bytes read since the newest pong at least :data:`RATE_SPAN` old (else the
        oldest kept, if :data:`FIRST_SPAN` old), per second."""
        pongs = self._pongs
        pongs.append((now, self.acked))
        while len(pongs) > 2 and now - pongs[1][0] >= RATE_SPAN:
            pongs.popleft()  # the second is old enough to measure from: the first is not needed
        at, acked = pongs[0]
        if now - at >= FIRST_SPAN:
            self.rate = (self.acked - acked) / (now - at)

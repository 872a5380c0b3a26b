"""The flight window, sans-I/O: bytes sent, pings and pongs with their times, no sockets."""

from __future__ import annotations

from hitrobot_server.transport.flight import (
    ARM_AGE,
    ARM_SPAN,
    DISARM_SPAN,
    FIRST_GIVE_UP,
    GIVE_UP,
    INITIAL_WINDOW,
    MAX_WINDOW,
    MIN_PING_EVERY,
    MIN_WINDOW,
    WATCH_EVERY,
    FlightWindow,
)


class Reader:
    """A client behind a deep buffer, stepped by the half millisecond: it reads what has
    arrived, up to ``chunk`` bytes at once, then waits as long as its link takes to bring that
    many (``rate`` bytes/s) — a browser on a slow link reads in such bursts. It answers each
    ping once it has read up to it. A sender sends ``frame``-byte frames while the window has
    room and the socket buffers (``KERNEL``) take them, and a small message every 20 ms ahead
    of them; the ages of those on arrival are kept."""

    STEP = 0.0005
    KERNEL = 4 * 1024 * 1024  # what the socket buffers take before the sender must wait

    def __init__(self, w: FlightWindow, *, rate: float, chunk: int = 256 * 1024,
                 frame: int = 16_000, kernel: int = KERNEL):
        self.w, self.rate, self.chunk, self.frame, self.kernel = w, rate, chunk, frame, kernel
        self.now = 0.0
        self.read_to = 0
        self.next_read = 0.0
        self.pings: list[int] = []
        self.poses: list[tuple[int, float]] = []  # (stream position, when sent)
        self.waiting: list[float] = []  # small messages not yet sent (server-side queue)
        self.ages: list[float] = []

    def run(self, seconds: float, *, rate: float | None = None, pause=None) -> None:
        """Step for ``seconds``; ``pause(now)`` True: the reader's process reads nothing."""
        if rate is not None:
            self.rate = rate
        w = self.w
        for _ in range(int(seconds / self.STEP)):
            self.now += self.STEP
            now = self.now
            if round(now / self.STEP) % 40 == 0:
                self.waiting.append(now)
            busy = pause is not None and pause(now)
            if not busy and now >= self.next_read and w.sent > self.read_to:
                got = min(w.sent - self.read_to, self.chunk)
                self.read_to += got
                for mark in [m for m in self.pings if m <= self.read_to]:
                    self.pings.remove(mark)
                    w.ponged(mark, now)
                    if w.stuck:  # as the transport does: a ping after the last bytes
                        self.pings.append(w.pinged(now))
                for pose in [p for p in self.poses if p[0] <= self.read_to]:
                    self.poses.remove(pose)
                    self.ages.append(now - pose[1])
                self.next_read = now + got / self.rate
            sends = 0
            while w.room(now) and w.sent - self.read_to < self.kernel and sends < 2000:
                sends += 1
                if self.waiting:
                    size, sent_at = 200, self.waiting.pop(0)
                else:
                    size, sent_at = self.frame, None
                if w.on_sent(size, now):
                    self.pings.append(w.pinged(now))
                if sent_at is not None:
                    self.poses.append((w.sent, sent_at))

    def p99_since(self, index: int) -> float:
        ages = sorted(self.ages[index:])
        return ages[int(0.99 * (len(ages) - 1))]


def test_a_new_window_is_open_and_pings_its_first_bytes():
    w = FlightWindow()
    assert w.open and w.window == INITIAL_WINDOW and w.in_flight == 0 and not w.armed
    assert w.on_sent(100, now=0.0)  # after idle: a bare round trip is measured
    mark = w.pinged(0.0)
    assert mark == 100 and w.in_flight == 100
    w.ponged(mark, 0.002)
    assert w.in_flight == 0 and w.base_rtt == 0.002


def test_a_client_not_held_is_never_closed_and_pinged_by_the_clock():
    """Until a client shows a standing queue the window only watches: far more than a window
    goes out, and a ping goes every WATCH_EVERY seconds, not every quarter window."""
    w = FlightWindow()
    w.pinged(0.0)
    asked = [w.on_sent(MIN_PING_EVERY, 0.01) for _ in range(100)]  # 1.6 MB
    assert not any(asked) and w.open and w.in_flight > 4 * w.window
    assert w.on_sent(1, WATCH_EVERY)


def test_a_slow_bursty_reader_is_held_and_its_small_messages_stay_fresh():
    """2 MB/s, reading 256 kB bursts off a deep buffer: once its pongs show a standing queue
    it is held, and what is sent to it after that is under 100 ms old when read, where an
    unbounded sender would queue seconds. Its link stays full."""
    w = FlightWindow()
    reader = Reader(w, rate=2_000_000)
    reader.run(ARM_AGE + ARM_SPAN + 0.5)
    assert w.armed
    reader.run(3.0)  # what the socket buffers took before it was held drains first
    settled, read_before = len(reader.ages), reader.read_to
    reader.run(3.0)
    assert reader.p99_since(settled) <= 0.1
    assert (reader.read_to - read_before) / 3.0 >= 0.95 * 2_000_000
    assert MIN_WINDOW <= w.window <= 2_000_000 * 0.1


def test_a_fast_reader_is_never_held():
    w = FlightWindow()
    reader = Reader(w, rate=500e6, frame=256_000)
    reader.run(1.0)
    assert not w.armed and w.open


def test_a_fast_reader_that_pauses_is_not_held():
    """A client that reads 100 MB/s but stops for 80 ms in every 250 (a busy process): late
    pongs now and then, quick ones in between. It is not a standing queue: the client is not
    held, and gets all it can read."""
    w = FlightWindow()
    reader = Reader(w, rate=100e6, frame=64_000)
    reader.run(3.0, pause=lambda now: (now % 0.25) < 0.08)
    assert not w.armed


def test_a_held_reader_that_speeds_up_is_let_go():
    w = FlightWindow()
    reader = Reader(w, rate=1_000_000)
    reader.run(2.0)
    assert w.armed
    slow_window = w.window
    reader.kernel = 512 * 1024  # a link that got fast: what is queued is read within ms
    reader.run(DISARM_SPAN + 1.0, rate=200e6)
    assert not w.armed and w.window > 4 * slow_window


def test_a_held_window_that_shrank_under_its_unpinged_bytes_asks_for_a_ping():
    """Held, the window shrinks below what no ping covers yet: without a ping now nothing
    would ever reopen it (no bytes go out while it is full)."""
    w = FlightWindow(initial=1024 * 1024)
    w.armed = True
    w.on_sent(100, 0.0)
    w.ponged(w.pinged(0.0), 0.001)  # a bare round trip of 1 ms
    marks = []
    while w.open:
        if w.on_sent(16_000, 0.01):
            marks.append(w.pinged(0.01))
    assert not w.stuck
    for i, mark in enumerate(marks):  # read at about 16 kB/s: the window shrinks to its minimum
        w.ponged(mark, 0.5 + i)
    assert w.window == MIN_WINDOW and not w.open and w.stuck
    w.ponged(w.pinged(20.0), 20.1)
    assert w.open and not w.stuck


def test_a_pong_acknowledges_every_earlier_ping_and_ignores_stale_ones():
    w = FlightWindow()
    first = (w.on_sent(1000, 0.0), w.pinged(0.0))[1]
    w.on_sent(70_000, 0.01)
    second = w.pinged(0.01)
    w.ponged(second, 0.05)
    assert w.acked == second
    w.ponged(first, 0.06)  # its pong after a later one's: nothing goes back
    assert w.acked == second


def test_late_pongs_arm_only_when_they_last_and_a_busy_server_loop_is_not_the_client():
    w = FlightWindow()
    t, mark = 0.0, 0
    for _ in range(4):  # late pongs, but not for ARM_SPAN yet
        w.on_sent(50_000, t)
        mark = w.pinged(t)
        t += 0.05
        w.ponged(mark, t + ARM_AGE + 0.05)
    assert not w.armed
    for _ in range(20):  # as late, but the server's loop ran as late itself: not the client
        w.on_sent(50_000, t)
        mark = w.pinged(t)
        t += 0.05
        w.ponged(mark, t + ARM_AGE + 0.05, lag=0.2)
    assert not w.armed
    for _ in range(20):
        w.on_sent(50_000, t)
        mark = w.pinged(t)
        t += 0.05
        w.ponged(mark, t + ARM_AGE + 0.05)
    assert w.armed and t > ARM_SPAN


def test_windows_stay_within_their_bounds():
    w = FlightWindow()
    Reader(w, rate=1e10, chunk=64 << 20, frame=1_000_000).run(0.3)
    assert w.window == MAX_WINDOW
    w = FlightWindow()
    Reader(w, rate=50_000, chunk=4096, frame=4_000, kernel=128 * 1024).run(5.0)
    assert w.armed and w.window == MIN_WINDOW


def test_a_held_client_that_does_not_pong_is_not_held_after_give_up():
    """A held client that stops answering pings would be stuck: after GIVE_UP seconds of
    silence (FIRST_GIVE_UP before any pong) the window stops holding it back, and its next
    pong arms it again."""
    w = FlightWindow(initial=MIN_WINDOW)
    w.armed = True
    marks = []
    while w.open:
        if w.on_sent(8192, 0.0):
            marks.append(w.pinged(0.0))
    assert not w.room(FIRST_GIVE_UP / 2)
    assert w.room(FIRST_GIVE_UP)  # the transport then sends as it would without a window
    w.ponged(marks[-1], 1.0)  # it answers after all: held again
    while w.open:
        if w.on_sent(8192, 1.0):
            w.pinged(1.0)
    assert not w.room(1.0 + FIRST_GIVE_UP) and not w.room(1.0 + GIVE_UP / 2)
    assert w.room(1.0 + GIVE_UP)

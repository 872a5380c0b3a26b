"""The flight window, sans-I/O: bytes sent, pings and pongs with their times, no sockets."""

from __future__ import annotations

from hitrobot_server.transport.flight import (
    FIRST_GIVE_UP,
    GIVE_UP,
    INITIAL_WINDOW,
    MAX_WINDOW,
    MIN_PING_EVERY,
    MIN_WINDOW,
    FlightWindow,
)


def drive(w: FlightWindow, *, rate: float, seconds: float, frame: int = 16_000,
          rtt0: float = 0.001, start: float = 0.0, pending: list[int] | None = None
          ) -> list[float]:
    """A client that reads ``rate`` bytes/s behind a deep buffer, stepped by the millisecond,
    and a sender that sends while the window lets it. Returns the queueing delay (unread bytes
    / rate) at each send."""
    read_to, delays = w.acked, []
    pending = [] if pending is None else pending  # pings not yet answered, kept across calls
    for step in range(int(seconds * 1000)):
        now = start + step / 1000
        read_to = min(w.sent, read_to + int(rate / 1000))
        for mark in [m for m in pending if m <= read_to]:
            pending.remove(mark)
            w.ponged(mark, now + rtt0)
            if w.stuck:  # as the transport does: a ping after the last bytes
                pending.append(w.pinged(now + rtt0))
        sends = 0
        while w.open and sends < 10_000:
            sends += 1
            delays.append(w.in_flight / rate)
            if w.on_sent(frame, now):
                pending.append(w.pinged(now))
    return delays


def test_a_new_window_is_open_and_pings_its_first_bytes():
    w = FlightWindow()
    assert w.open and w.window == INITIAL_WINDOW and w.in_flight == 0
    assert w.on_sent(100, now=0.0)  # after idle: a bare round trip is measured
    mark = w.pinged(0.0)
    assert mark == 100 and w.in_flight == 100
    w.ponged(mark, 0.002)
    assert w.in_flight == 0 and w.base_rtt == 0.002


def test_pings_go_every_quarter_window_and_when_it_fills():
    w = FlightWindow(initial=256 * 1024)
    w.pinged(0.0)  # the first probe is out of the way
    asked = [w.on_sent(MIN_PING_EVERY, 0.01) for _ in range(3)]
    assert asked == [False, False, False]
    assert w.on_sent(MIN_PING_EVERY, 0.01)  # 64 kB = a quarter of the window
    w.pinged(0.01)
    assert not w.on_sent(1, 0.01)
    assert w.on_sent(256 * 1024, 0.01) and not w.open  # full: ping now, or nothing reopens it


def test_the_window_closes_at_its_size_and_reopens_on_the_pong():
    w = FlightWindow(initial=MIN_WINDOW)
    marks = []
    while w.open:
        if w.on_sent(8192, 0.0):
            marks.append(w.pinged(0.0))
    # the pings out cover all but under half a window: their pongs reopen it, no ping more
    assert w.in_flight >= w.window and not w.stuck and w.sent - marks[-1] < w.window // 2
    w.ponged(marks[-1], 0.5)
    assert w.open and w.in_flight == w.sent - marks[-1]


def test_a_window_that_shrank_under_its_unpinged_bytes_asks_for_a_ping():
    """The pongs of a slow reader shrink the window below what no ping covers yet: without a
    ping now nothing would ever reopen it (no bytes go out while it is full)."""
    w = FlightWindow(initial=1024 * 1024)
    w.on_sent(100, 0.0)
    w.ponged(w.pinged(0.0), 0.001)  # a bare round trip of 1 ms
    marks = []
    while w.open:
        if w.on_sent(16_000, 0.01):
            marks.append(w.pinged(0.01))
    assert not w.stuck
    for i, mark in enumerate(marks):  # read at 100 kB/s: the window shrinks to its minimum
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


def test_a_slow_reader_gets_a_window_of_about_the_target_delay():
    """2 MB/s behind a deep buffer: the unread bytes settle near rate x (base rtt + target),
    where an unbounded sender would queue seconds."""
    w = FlightWindow()
    delays = drive(w, rate=2_000_000, seconds=3.0)
    settled = sorted(delays[len(delays) // 2:])
    p99 = settled[int(0.99 * (len(settled) - 1))]
    assert p99 <= 0.1, p99
    assert MIN_WINDOW <= w.window <= 2_000_000 * 0.1


def test_a_fast_reader_opens_the_window_up_to_its_bound():
    w = FlightWindow()
    drive(w, rate=1e9, seconds=0.2, frame=256_000)
    assert w.window == MAX_WINDOW


def test_a_reader_that_slows_down_gets_a_smaller_window():
    w, pings = FlightWindow(), []
    drive(w, rate=50_000_000, seconds=1.0, pending=pings)
    fast = w.window
    drive(w, rate=1_000_000, seconds=4.0, start=1.0, pending=pings)
    assert w.window < fast / 4 and w.window <= 1_000_000 * 0.1


def test_a_fast_reader_that_pauses_keeps_its_rate():
    """A client that reads 100 MB/s but stops for 80 ms in every 250 (a busy process, a loop
    that also publishes): late pongs now and then, but no standing queue. The window leaves it
    what it can read, about what a sender without a window delivers."""
    w, pings, read_to, read = FlightWindow(), [], 0, 0
    for step in range(3000):  # 3 s by the millisecond
        now = step / 1000
        if step % 250 >= 80:  # reading: 100 kB a millisecond, a pong for each ping read
            read_to = min(w.sent, read_to + 100_000)
            for mark in [m for m in pings if m <= read_to]:
                pings.remove(mark)
                w.ponged(mark, now)
                if w.stuck:
                    pings.append(w.pinged(now))
        sends = 0
        while w.room(now) and sends < 1000:  # the sender always has more (a flood)
            sends += 1
            if w.on_sent(16_000, now):
                pings.append(w.pinged(now))
        if step == 1000:
            read = read_to
    assert (read_to - read) / 2.0 >= 0.95 * 100e6 * 170 / 250  # 95 % of what it can read


def test_a_client_that_does_not_pong_is_not_held_after_give_up():
    """A WebSocket client that does not answer pings would be stuck at its first window: after
    FIRST_GIVE_UP seconds (GIVE_UP once it has answered one) of silence the window stops
    holding it back, and its next pong arms it again."""
    w = FlightWindow(initial=MIN_WINDOW)
    marks = []
    while w.open:
        if w.on_sent(8192, 0.0):
            marks.append(w.pinged(0.0))
    assert not w.room(FIRST_GIVE_UP / 2)
    assert w.room(FIRST_GIVE_UP)  # the transport then sends as it would without a window
    w.ponged(marks[-1], 1.0)  # it answers after all: armed again
    while w.open:
        if w.on_sent(8192, 1.0):
            w.pinged(1.0)
    assert not w.room(1.0 + FIRST_GIVE_UP) and not w.room(1.0 + GIVE_UP / 2)
    assert w.room(1.0 + GIVE_UP)

"""The drive lease as pure logic over a clock the test moves (nodes/ground/drive_lease.py)."""

from __future__ import annotations

from hitrobot_server.bus.topics import Origin
from hitrobot_server.nodes.ground.drive_lease import (
    LAPSE,
    DriveLease,
    Verdict,
    driver_name,
    may_take_over,
)


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def lease() -> tuple[DriveLease, Clock]:
    clock = Clock()
    return DriveLease(clock), clock


def test_the_first_moving_command_takes_the_lease_and_another_is_refused():
    drive, clock = lease()
    verdict, change = drive.ask("/a", "alice", moving=True)
    assert verdict is Verdict.DRIVE
    assert change is not None and change.holder is not None and change.holder.name == "alice"
    assert not change.stop
    clock.now += 0.3
    assert drive.ask("/b", "bob", moving=True) == (Verdict.REFUSE, None)
    assert drive.ask("/b", "bob", moving=False) == (Verdict.REFUSE, None)
    assert drive.ask("/a", "alice", moving=True) == (Verdict.DRIVE, None)
    assert drive.holder is not None and drive.holder.since == 100.0


def test_a_stop_takes_nothing_and_a_lease_lapses_after_the_last_moving_command():
    drive, clock = lease()
    assert drive.ask("/a", "alice", moving=False) == (Verdict.IDLE_STOP, None)
    assert drive.holder is None and drive.due() is None
    drive.ask("/a", "alice", moving=True)
    clock.now += 0.4
    drive.ask("/a", "alice", moving=True)  # renewed
    assert drive.due() == clock.now + LAPSE
    clock.now += LAPSE - 0.01
    assert drive.expire() is None
    clock.now += 0.01
    change = drive.expire()
    assert change is not None and change.holder is None and change.reason == "lapsed"
    assert change.previous is not None and change.previous.name == "alice"
    assert change.stop  # alice was still moving the robot: one stop
    assert drive.expire() is None  # exactly one
    verdict, taken = drive.ask("/b", "bob", moving=True)
    assert verdict is Verdict.DRIVE and taken is not None and taken.holder.name == "bob"


def test_a_holder_that_stopped_gets_no_second_stop_and_its_stops_do_not_renew():
    drive, clock = lease()
    drive.ask("/a", "alice", moving=True)
    clock.now += 0.2
    assert drive.ask("/a", "alice", moving=False) == (Verdict.DRIVE, None)
    clock.now += 0.2
    drive.ask("/a", "alice", moving=False)
    clock.now += 0.1  # 0.5 s after the last moving command, stops since
    change = drive.expire()
    assert change is not None and not change.stop


def test_a_disconnect_ends_only_its_own_lease_with_a_stop():
    drive, _clock = lease()
    drive.ask("/a", "alice", moving=True)
    assert drive.leave("/b") is None
    change = drive.leave("/a")
    assert change is not None and change.reason == "disconnected" and change.stop
    assert drive.holder is None


def test_a_take_over_stops_the_holder_and_lapses_unless_the_taker_drives():
    drive, clock = lease()
    drive.ask("/a", "alice", moving=True)
    change = drive.take("/root", "root")
    assert change.holder is not None and change.holder.name == "root"
    assert change.previous is not None and change.previous.name == "alice" and change.stop
    assert change.reason == "taken over by root"
    assert drive.ask("/a", "alice", moving=True) == (Verdict.REFUSE, None)
    assert drive.take("/root", "root").reason == "already held"
    clock.now += LAPSE
    ended = drive.expire()
    assert ended is not None and not ended.stop  # root never moved the robot


def test_a_driver_is_named_by_its_token_once_it_has_one_and_admins_take_over():
    assert driver_name(Origin("/rosbridge_client_7")) == "/rosbridge_client_7"
    assert driver_name(Origin("/rosbridge_client_7", name="tablet-3")) == "tablet-3"
    assert may_take_over(Origin("/c", role="operator"), authenticate=False)
    assert may_take_over(Origin("/c", role="admin"), authenticate=True)
    assert not may_take_over(Origin("/c", role="operator"), authenticate=True)
    assert not may_take_over(Origin("/c", role="none"), authenticate=True)

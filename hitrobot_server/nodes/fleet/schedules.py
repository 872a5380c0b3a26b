"""Recurring tasks: "every 2 h" (also ``min``, ``s``) from the time it was added, or
"daily 09:00" in the site's time zone.

A slot missed while the server was down is reported (the schedule's message and the log) and
the policy is **run once**: however many slots were missed, the task runs once at start, then
the schedule goes on from the next slot after now.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass

MAX_SCHEDULES = 100
MIN_PERIOD = 10.0  # seconds: "every" shorter than this is refused
_EVERY = re.compile(r"every\s+(\d+(?:\.\d+)?)\s*(h|hours?|min|minutes?|s|seconds?)", re.I)
_DAILY = re.compile(r"daily\s+(\d{1,2}):(\d{2})", re.I)
_UNIT = {"h": 3600.0, "m": 60.0, "s": 1.0}


class ScheduleError(ValueError):
    """A ``when`` that cannot be read; the text says why."""


@dataclass
class Schedule:
    id: int
    when: str
    task: dict  # the dispatch request it makes
    added: float  # Unix time
    next: float = 0.0  # the next slot (Unix time)
    last: float = 0.0  # the last slot it fired for
    message: str = ""

    def msg(self) -> dict:
        t = self.task
        return {"id": self.id, "when": self.when, "kind": t.get("kind", ""),
                "poi": t.get("poi", ""), "pois": list(t.get("pois", [])),
                "robot": t.get("robot", ""), "next": self.next, "last": self.last,
                "message": self.message}

    def record(self) -> dict:
        return {"id": self.id, "when": self.when, "task": self.task, "added": self.added,
                "next": self.next, "last": self.last, "message": self.message}

    @classmethod
    def from_record(cls, r: dict) -> Schedule:
        return cls(int(r["id"]), str(r["when"]), dict(r["task"]), float(r["added"]),
                   float(r["next"]), float(r["last"]), str(r["message"]))


def parse(when: str) -> tuple[str, float]:
    """``("every", seconds)`` or ``("daily", seconds after midnight)``."""
    text = when.strip()
    if match := _EVERY.fullmatch(text):
        seconds = float(match[1]) * _UNIT[match[2][0].lower()]
        if not (math.isfinite(seconds) and seconds >= MIN_PERIOD):
            raise ScheduleError(f"when: every must be at least {MIN_PERIOD:g} s")
        return "every", seconds
    if match := _DAILY.fullmatch(text):
        hour, minute = int(match[1]), int(match[2])
        if hour > 23 or minute > 59:
            raise ScheduleError(f"when: {hour:02d}:{minute:02d} is not a time of day")
        return "daily", hour * 3600.0 + minute * 60.0
    raise ScheduleError(f"when: '{when}' is neither 'every N h|min|s' nor 'daily HH:MM'")


def slot_after(schedule: Schedule, now: float, zone: dt.tzinfo) -> float:
    """The first slot of ``schedule`` strictly after ``now``."""
    kind, value = parse(schedule.when)
    if kind == "every":
        laps = math.floor((now - schedule.added) / value) + 1
        return schedule.added + max(1, laps) * value
    local = dt.datetime.fromtimestamp(now, zone)
    day = local.replace(hour=0, minute=0, second=0, microsecond=0)
    for days in range(3):
        slot = (day + dt.timedelta(days=days)).replace(tzinfo=None) + dt.timedelta(
            seconds=value)
        at = slot.replace(tzinfo=zone).timestamp()
        if at > now:
            return at
    raise AssertionError("a daily slot is always within two days")


def missed(schedule: Schedule, now: float, zone: dt.tzinfo) -> int:
    """How many slots passed between ``schedule.next`` and ``now`` (bounded count)."""
    count, slot = 0, schedule.next
    while slot <= now and count < 10_000:
        count += 1
        slot = slot_after(schedule, slot, zone)
    return count

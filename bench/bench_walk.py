"""How far one op travels through our code: files and calls on the way, counted.

A reader follows one ``publish`` from the frame a client sends to the bytes another client's
outbox hands its transport, and one ``call_service`` from the frame to the reply's bytes. This
script makes that walk measurable: it runs the real session and bus without sockets (two
sessions on one bus, as the transports would drive them), profiles the walk with
``sys.setprofile`` and prints how many of our files and functions were entered and how many
calls were made. Fewer is a shorter walk for a reader, not a speed claim (``bench_bridge.py``
measures speed).

    .venv/bin/python bench/bench_walk.py
"""

from __future__ import annotations

import asyncio
import json
import sys
from collections import Counter
from pathlib import Path

import hitrobot_server
from hitrobot_server.bus.core import Bus
from hitrobot_server.session.options import SessionOptions
from hitrobot_server.session.rosbridge.session import Session, Shared
from hitrobot_server.types.registry import TypeRegistry

PACKAGE = str(Path(hitrobot_server.__file__).parent)
TOPIC = "/walk/chatter"


class Walk:
    """Counts calls into hitrobot_server while it is switched on."""

    def __init__(self) -> None:
        self.calls: Counter[tuple[str, str]] = Counter()

    def __call__(self, frame, event, arg) -> None:
        if event == "call" and frame.f_code.co_filename.startswith(PACKAGE):
            rel = frame.f_code.co_filename[len(PACKAGE) + 1:]
            self.calls[(rel, frame.f_code.co_qualname)] += 1

    def report(self, name: str) -> None:
        files = sorted({f for f, _ in self.calls})
        print(f"{name}: {len(files)} files, {len(self.calls)} functions, "
              f"{sum(self.calls.values())} calls")
        for f in files:
            names = [q for g, q in self.calls if g == f]
            print(f"    {f}: {', '.join(sorted(names))}")


async def drain(session: Session) -> list:
    """What the session's transport would write next (one batch)."""
    frames = await asyncio.wait_for(session.outbox.get(), 5)
    session.outbox.sent()
    return frames


async def walk(name: str, sender: Session, receiver: Session, op: dict) -> None:
    tracer = Walk()
    text = json.dumps(op)
    sys.setprofile(tracer)
    try:
        pending = sender.receive(text)
        if pending is not None:
            await pending
        await drain(receiver)
    finally:
        sys.setprofile(None)
    tracer.report(name)


async def main() -> None:
    bus = Bus(TypeRegistry.default())
    options = SessionOptions()
    shared = Shared.for_options(options)
    a = Session(bus, options, peer="walk-a", shared=shared)
    b = Session(bus, options, peer="walk-b", shared=shared)
    for session, op in ((a, {"op": "advertise", "topic": TOPIC, "type": "std_msgs/String"}),
                        (b, {"op": "subscribe", "topic": TOPIC, "type": "std_msgs/String"})):
        pending = session.receive(json.dumps(op))
        if pending is not None:
            await pending
    # one publish untraced first, so first-use caches are warm in both walks
    a.receive(json.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": "warm"}}))
    await drain(b)
    await walk("publish", a, b, {"op": "publish", "topic": TOPIC, "msg": {"data": "hello"}})

    async def echo(request: dict) -> dict:
        return {"success": True, "message": "pong"}

    bus.advertise_service("/walk/echo", "std_srvs/Trigger", "walk", "walk", echo)
    call = {"op": "call_service", "id": "c1", "service": "/walk/echo",
            "type": "std_srvs/Trigger", "args": {}}
    a.receive(json.dumps(call))
    await drain(a)
    await walk("call_service", a, a, {**call, "id": "c2"})
    a.close()
    b.close()


if __name__ == "__main__":
    asyncio.run(main())

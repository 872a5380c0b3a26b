"""The state store: which crash-safe design, and what kill -9 does. Prints figures only.

1. Design: a state holding a big map (``--map-mb``, 4 MB by default: 2000 x 2000 cells) and
   some POIs, changed by (a) one small POI edit, (b) a burst of 100 POI edits, (c) a burst of
   100 map edits, written by
   - **journal**: our :class:`StateStore` (a checksummed journal line per coalesced batch,
     content-addressed blobs for big values, a snapshot when the journal grows), and
   - **replace**: the whole state rewritten per change (temporary file, fsync, rename, fsync
     the folder) - the other design the issue names; per-key files would be cheaper but lose
     the prefix property across keys (a crash between two files leaves them out of step).
2. kill -9: a real server (simulated robot) gets a burst of 200 POIs on ``/map_manager/add_poi``
   (at most 20 unacknowledged in flight) and is SIGKILLed after a seeded number of
   acknowledgements; restarted on the same folder, it is asked for its POIs. Prints sent /
   acknowledged / kept / prefix? per run.

    python bench/bench_state.py [--map-mb 4] [--kills 5]

Timings on a shared machine are indicative only.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from hitrobot_server.state import StateStore  # noqa: E402

WINDOW = 20
"""Requests in flight: the client keeps sending while the acknowledgements come back, so the
kill lands in the middle of the burst (with up to this many changes unacknowledged)."""
POI = {"type": 100, "remarks": "", "pose": {"position": {"x": 1.0, "y": 2.0, "z": 0.0},
                                              "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}


def replace_write(path: Path, pois: list, map_bytes: bytes) -> None:
    """The other design: the whole state, atomically replaced and fsynced."""
    head = json.dumps({"pois": pois, "map_size": len(map_bytes)}).encode()
    tmp = path.with_suffix(".tmp")
    with open(tmp, "wb") as f:
        f.write(len(head).to_bytes(8, "big") + head + map_bytes)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    fd = os.open(path.parent, os.O_RDONLY)
    os.fsync(fd)
    os.close(fd)


async def design(map_mb: float) -> None:
    big = os.urandom(int(map_mb * 1024 * 1024))
    pois = [{**POI, "name": f"p{i}"} for i in range(50)]
    print(f"1. design: state = {len(big) / 1e6:.1f} MB map + {len(pois)} POIs")
    print(f"   {'change':<26} {'journal':>20} {'replace':>20}")
    with tempfile.TemporaryDirectory() as tmp:
        store = StateStore.open(Path(tmp) / "j")
        store.put("map", big)
        store.put("pois", pois)
        await store.flush()
        target = Path(tmp) / "state.bin"
        replace_write(target, pois, big)

        async def journal(changes: list[tuple[str, object]]) -> tuple[float, int]:
            writes = store.writes
            t = time.perf_counter()
            futures = [store.put(k, v) for k, v in changes]
            await asyncio.gather(*futures)
            return time.perf_counter() - t, store.writes - writes

        def replace(changes: list[tuple[str, object]]) -> tuple[float, int]:
            t = time.perf_counter()
            m, p = big, pois
            for key, value in changes:
                m, p = (value, p) if key == "map" else (m, value)
                replace_write(target, p, m)
            return time.perf_counter() - t, len(changes)

        cases = {
            "1 POI edit": [("pois", [*pois, {**POI, "name": "new"}])],
            "100 POI edits (burst)": [("pois", [*pois, {**POI, "name": f"n{i}"}])
                                      for i in range(100)],
            "100 map edits (burst)": [("map", big[:-1] + bytes([i])) for i in range(100)],
        }
        for name, changes in cases.items():
            jt, jw = await journal(changes)
            rt, rw = await asyncio.to_thread(replace, changes)
            print(f"   {name:<26} {jt * 1e3:9.1f} ms {jw:3d} wr {rt * 1e3:9.1f} ms {rw:3d} wr")
        await store.close()
        size = sum(p.stat().st_size for p in (Path(tmp) / "j").rglob("*") if p.is_file())
        print(f"   on disk after the runs: journal design {size / 1e6:.1f} MB (blobs of old "
              "maps are dropped at the next snapshot)")


def start(state: Path) -> tuple[subprocess.Popen, int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "0",
         "--address", "127.0.0.1", "--state-dir", str(state), "--map-dir",
         str(state / "maps"), "--log-level", "warning"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)})
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if m := re.search(r"ws://[\d.]+:(\d+)", line):
            return proc, int(m.group(1))
        if not line:
            break
    proc.kill()
    raise RuntimeError("server did not start")


async def kills(runs: int) -> None:
    from websockets.asyncio.client import connect

    print(f"2. kill -9 during a burst of 200 POIs ({runs} runs, seeded)")
    print(f"   {'run':>3} {'kill after':>10} {'sent':>5} {'acked':>6} {'kept':>5} {'prefix':>7}")
    rng = random.Random(21)
    for run in range(runs):
        with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as tmp:
            state = Path(tmp)
            proc, port = start(state)
            names = [f"b{i:03d}" for i in range(200)]
            wanted = set(names)
            kill_after = rng.randrange(1, 200)
            acked: list[str] = []
            async with connect(f"ws://127.0.0.1:{port}", max_size=None) as ws:
                await ws.send(json.dumps({"op": "set_level", "level": "info"}))
                await ws.send(json.dumps({"op": "advertise", "topic": "/map_manager/add_poi",
                                          "type": "map_messages/PointOfInterest"}))
                sent = 0
                deadline = time.monotonic() + 60
                while len(acked) < kill_after and time.monotonic() < deadline:
                    while sent < len(names) and sent < len(acked) + WINDOW:
                        await ws.send(json.dumps({
                            "op": "publish", "topic": "/map_manager/add_poi",
                            "id": names[sent], "msg": {**POI, "name": names[sent]}}))
                        sent += 1
                    msg = json.loads(await asyncio.wait_for(ws.recv(), 30))
                    if msg.get("op") == "status" and msg.get("level") == "info" \
                            and msg.get("id") in wanted:
                        acked.append(msg["id"])
                sent_at_kill = sent
                proc.kill()
            proc.wait()
            proc, port = start(state)
            async with connect(f"ws://127.0.0.1:{port}", max_size=None) as ws:
                await ws.send(json.dumps({"op": "call_service", "id": "g",
                                          "service": "/map_manager/get_pois"}))
                while True:
                    msg = json.loads(await asyncio.wait_for(ws.recv(), 30))
                    if msg.get("op") == "service_response":
                        break
            proc.kill()
            proc.wait()
            kept = [p["name"] for p in msg["values"]["poi_list"]["pois"]]
            prefix = kept == names[:len(kept)] and set(acked) <= set(kept)
            print(f"   {run:>3} {kill_after:>10} {sent_at_kill:>5} {len(acked):>6} "
                  f"{len(kept):>5} {'yes' if prefix else 'NO':>7}")


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--map-mb", type=float, default=4.0)
    parser.add_argument("--kills", type=int, default=5)
    args = parser.parse_args()
    await design(args.map_mb)
    await kills(args.kills)


if __name__ == "__main__":
    asyncio.run(main())

"""Every acknowledged fleet change is kept (issue 45, item 3): a real ``hitrobot-server`` process
is killed with SIGKILL right after each answer arrives (nothing of the server runs after it),
and the change comes back after the restart on the same state folder as it was answered.

Cancel, pause, resume, set_in_service (both ways), a schedule add and a zone add: before the
acknowledgement table only ``/fleet/dispatch`` waited for the disk on a single server."""

from __future__ import annotations

from tests.helpers import ServerProcess, Watcher
from tests.nodes.fleet.test_node import Y, pose
from tests.nodes.fleet.test_zones import polygon
from tests.state.failing_folder import FailingFolder

QUEUED = 20
"""Tasks queued before the disk fails: their section (each change writes it whole) needs more
than the last page the full disk has left."""
DOOR = [(14.0, 7.2), (15.0, 7.2), (15.0, 8.8), (14.0, 8.8)]


class Restarts:
    """One server at a time on one state folder, killed after an answer and started again."""

    def __init__(self, tmp_path):
        self.args = ("--sim-speed", "4", "--state-dir", str(tmp_path / "state"),
                     "--map-dir", str(tmp_path / "m"))
        self.server: ServerProcess | None = None
        self.w: Watcher | None = None

    async def start(self) -> Watcher:
        self.server = ServerProcess(*self.args, robot="a=sim@6,8")
        self.w = await Watcher.open(self.server.port)
        for topic in ("/fleet/robots", "/fleet/tasks", "/fleet/zones"):
            await self.w.subscribe(topic)
        await self.w.until(lambda: [r["name"] for r in (
            self.w.latest("/fleet/robots") or {"robots": []})["robots"]] == ["a"], 30,
            "robot a heard")
        return self.w

    async def answered_then_killed(self, service: str, args: dict) -> dict:
        """Call ``service``; the server is killed as soon as its answer is here."""
        assert self.server is not None and self.w is not None
        reply = await self.w.call(service, args, timeout=30)
        self.server.kill()
        await self.w.close()
        self.server.stop()
        assert reply["result"] and reply["values"].get("success", True), reply
        return reply["values"]

    def stop(self) -> None:
        if self.server is not None:
            self.server.stop()


def robot_a(w: Watcher) -> dict:
    return next(r for r in w.latest("/fleet/robots")["robots"] if r["name"] == "a")


def task_state(w: Watcher, task_id: int) -> str:
    latest = w.latest("/fleet/tasks") or {"tasks": []}
    return next((t["state"] for t in latest["tasks"] if t["id"] == task_id), "")


async def test_each_fleet_change_answered_survives_a_kill_right_after_its_answer(tmp_path):
    r = Restarts(tmp_path)
    try:
        await r.start()
        await r.answered_then_killed("/fleet/set_in_service", {"robot": "a", "in_service": False})
        w = await r.start()
        assert robot_a(w)["in_service"] is False
        # a task named for a robot out of service waits for it: queued, kept across restarts
        task = (await w.call("/fleet/dispatch", {"poi": "", "pose": pose(10.0, Y), "robot": "a"},
                             timeout=30))["values"]
        assert task["accepted"], task
        await r.answered_then_killed("/fleet/pause", {"task": task["task"]})
        w = await r.start()
        await w.until(lambda: task_state(w, task["task"]) == "paused", 5, "the task paused")
        await r.answered_then_killed("/fleet/resume", {"task": task["task"]})
        w = await r.start()
        await w.until(lambda: task_state(w, task["task"]) == "queued", 5, "the task queued")
        await r.answered_then_killed("/fleet/cancel", {"task": task["task"]})
        w = await r.start()
        history = (await w.call("/fleet/history", {"robot": "", "limit": 5}))["values"]["tasks"]
        assert [(t["id"], t["state"]) for t in history] == [(task["task"], "cancelled")]
        assert task_state(w, task["task"]) in ("", "cancelled")

        added = await r.answered_then_killed("/fleet/schedule_add", {
            "when": "every 2 h", "poi": "", "pose": pose(12.0, Y), "robot": "a", "kind": ""})
        w = await r.start()
        listed = (await w.call("/fleet/schedule_list", {}))["values"]["schedules"]
        assert [(s["id"], s["when"]) for s in listed] == [(added["id"], "every 2 h")]

        await r.answered_then_killed("/fleet/zone_add", {"name": "door_c", "kind": "door",
                                                         "polygon": polygon(DOOR)})
        w = await r.start()
        zones = (await w.call("/fleet/zone_list", {}))["values"]["zones"]
        assert [(z["name"], [(p["x"], p["y"]) for p in z["polygon"]["points"]])
                for z in zones] == [("door_c", DOOR)]

        await r.answered_then_killed("/fleet/set_in_service", {"robot": "a", "in_service": True})
        w = await r.start()
        assert robot_a(w)["in_service"] is True
        await w.close()
    finally:
        r.stop()


async def test_a_fleet_change_the_disk_cannot_take_is_not_answered_as_done(tmp_path):
    """The disk full (or the folder read-only): pause and set_in_service answer the store's
    reason, not success (they used to answer at once, before the write)."""
    folder = FailingFolder(tmp_path / "state")
    args = ("--sim-speed", "4", "--state-dir", str(folder.root), "--map-dir", str(tmp_path / "m"))
    server = ServerProcess(*args, robot="a=sim@6,8")
    try:
        w = await Watcher.open(server.port)
        await w.subscribe("/fleet/robots")
        await w.until(lambda: (w.latest("/fleet/robots") or {"robots": []})["robots"], 30,
                      "robot a heard")
        await w.call("/fleet/set_in_service", {"robot": "a", "in_service": False})
        for _ in range(QUEUED):  # the open tasks' section: longer than a page
            task = (await w.call("/fleet/dispatch", {"poi": "", "pose": pose(10.0, Y),
                                                     "robot": "a"}, timeout=30))["values"]
            assert task["accepted"], task
        folder.fail(folder.root)
        for service, request in (("/fleet/pause", {"task": task["task"]}),
                                 ("/fleet/set_in_service", {"robot": "a", "in_service": True})):
            reply = await w.call(service, request, timeout=30)
            assert not reply["result"], (service, reply)
            assert f"not saved to the state folder: {folder.reason}" in str(reply["values"])
        await w.close()
    finally:
        server.stop()
        folder.close()

"""Nothing acknowledged that is not durable (issue 36, item 2, the state part): with the
state folder's disk full a POI is refused with the reason and not applied, the diagnostics
say "saving: no: disk full" while it lasts, and after a kill -9 exactly the acknowledged
POIs come back. The disk is really full (a small tmpfs filled to its last page) when the
test may mount one; otherwise the folder is made read-only by its modes (see
:mod:`.failing_folder`)."""

from __future__ import annotations

from tests.helpers import ServerProcess, Watcher
from tests.nodes.map_manager.util import MM, poi, request
from tests.state.failing_folder import FailingFolder
from tests.state.test_restart import diagnostic, value

POI_T = "map_messages/PointOfInterest"
LONG = "x" * 6000  # a journal line longer than a page: it needs space the disk no longer has


async def pois(w: Watcher) -> list[str]:
    reply = await w.call(f"{MM}/get_pois")
    return [p["name"] for p in reply["values"]["poi_list"]["pois"]]


def server(state) -> ServerProcess:
    return ServerProcess("--state-dir", str(state), "--map-dir", str(state.parent / "maps"),
                         robot="sim")


async def test_a_poi_the_disk_cannot_take_is_refused_and_not_applied(tmp_path):
    folder = FailingFolder(tmp_path / "state")
    try:
        first = server(folder.root)
        try:
            w = await Watcher.open(first.port)
            await w.client.send({"op": "set_level", "level": "info"})
            await w.subscribe("/diagnostics_agg")
            await w.subscribe(f"{MM}/pois")
            assert (await request(w, f"{MM}/add_poi", POI_T, poi("before_full", 3.0, 8.0),
                                  "p1"))["level"] == "info"
            folder.fail(folder.root / "sim-office")
            refused = await request(w, f"{MM}/add_poi", POI_T,
                                    poi("while_full", 4.0, 8.0, remarks=LONG), "p2")
            assert refused["level"] == "error", refused
            assert f"not saved to the state folder: {folder.reason}" in refused["msg"]
            assert "taken back" in refused["msg"]
            assert await pois(w) == ["before_full"]
            await w.until(lambda: [p["name"] for p in w.latest(f"{MM}/pois")["pois"]]
                          == ["before_full"], 10, "the latched list without it")
            item = await w.until(
                lambda: (d := diagnostic(w, "/Bridge/State")) and d["level"] == 2 and d, 10,
                "the store's entry saying it is not saving")
            assert value(item, "saving") == f"no: {folder.reason}"
            folder.free()
            assert (await request(w, f"{MM}/add_poi", POI_T, poi("after_full", 5.0, 8.0),
                                  "p3"))["level"] == "info"
            item = await w.until(
                lambda: (d := diagnostic(w, "/Bridge/State")) and value(d, "saving") == "yes"
                and d, 10, "saving again")
            await w.close()
        finally:
            first.kill()
        second = server(folder.root)
        try:
            w = await Watcher.open(second.port)
            assert await pois(w) == ["before_full", "after_full"]
            await w.close()
        finally:
            second.stop()
    finally:
        folder.close()

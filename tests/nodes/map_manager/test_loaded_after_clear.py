"""After ``clear_map`` no saved map is loaded any more (issue 46, friction 8: the console kept
"office_v1 · loaded" after the robot's map was cleared): the map manager hears the Slamware
node's answer and says so on the latched ``loaded_map``, after a restart too."""

from __future__ import annotations

from tests.helpers import Watcher
from tests.nodes.map_manager.util import MM, request

CLEAR = "/slamware_ros_sdk_server_node/clear_map"


async def test_clear_map_unloads_the_saved_map(make_server, tmp_path):
    state = tmp_path / "state"
    server = await make_server(robot="sim", sim_speed=4, map_dir=str(tmp_path / "maps"),
                               state_dir=str(state))
    w = await Watcher.open(server.port)
    try:
        await w.client.send({"op": "set_level", "level": "info"})
        await w.subscribe(f"{MM}/loaded_map", "std_msgs/String")
        for op in ("save_map", "load_map"):
            reply = await request(w, f"{MM}/{op}", "map_messages/SaveMap",
                                  {"filename": "office_v1"}, op, timeout=30)
            assert reply["level"] == "info", reply
        await w.until(lambda: (w.latest(f"{MM}/loaded_map") or {}).get("data") == "office_v1",
                      10, "office_v1 loaded")
        refused = await request(w, CLEAR, "slamware_ros_sdk/ClearMapRequest",
                                {"kind": {"kind": 99}}, "bad")
        assert refused["level"] == "error", refused  # refused: still loaded
        cleared = await request(w, CLEAR, "slamware_ros_sdk/ClearMapRequest",
                                {"kind": {"kind": 0}}, "clear", timeout=30)
        assert cleared["level"] == "info" and "cleared" in cleared["msg"], cleared
        await w.until(lambda: w.latest(f"{MM}/loaded_map")["data"] == "", 10, "none loaded")
    finally:
        await w.close()
    await server.stop()
    again = await make_server(robot="sim", sim_speed=4, map_dir=str(tmp_path / "maps"),
                              state_dir=str(state))
    w = await Watcher.open(again.port)
    try:
        await w.subscribe(f"{MM}/loaded_map", "std_msgs/String")
        await w.until(lambda: w.latest(f"{MM}/loaded_map") is not None, 10, "loaded_map")
        assert w.latest(f"{MM}/loaded_map")["data"] == ""
    finally:
        await w.close()

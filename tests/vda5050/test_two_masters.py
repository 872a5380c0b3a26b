"""One robot, two masters: a robot running a VDA 5050 order is busy on /fleet/robots (saying
whose order) and starts no fleet task; a fleet task or a console's motion makes the vehicle
refuse a new order (orderError); a console's cancel of a VDA 5050 order reaches the master as
the order cancelled (nothing left ahead, an error naming the order)."""

from __future__ import annotations

from hitrobot_server.robot.options import RobotEntry
from hitrobot_server.vda5050 import errors as e
from tests.helpers import Watcher
from tests.nodes.fleet.test_node import add_poi, dispatch, robots
from tests.vda5050.master import Master, has_error, node

Y = 8.0
NS = "/slamware_ros_sdk_server_node"


async def site(make_server, broker, tmp_path):
    server = await make_server(
        robots=(RobotEntry("a", "sim", (4.0, Y, 0.0)), RobotEntry("b", "sim", (12.0, Y, 0.0))),
        map_dir=str(tmp_path), vda5050=broker.url)
    w = await Watcher.open(server.port)
    for topic in ("/fleet/robots", "/fleet/tasks", "/map_manager/pois", "/vda5050/link"):
        await w.subscribe(topic)
    await w.until(lambda: sorted(n for n, r in robots(w).items() if r["state"] == "idle")
                  == ["a", "b"], 20, "both robots idle")
    return server, w


async def test_a_robot_on_a_vda_order_is_busy_and_gets_no_fleet_task(make_server, broker,
                                                                       tmp_path):
    server, w = await site(make_server, broker, tmp_path)
    try:
        async with Master(broker.port, serial="a") as master:
            here = (await master.sync())["agvPosition"]
            await master.order("job", 0, [node("s", 0, here["x"], here["y"]),
                                          node("t", 2, here["x"] + 3.0, here["y"])])
            await w.until(lambda: "busy with VDA 5050 order job" in
                          robots(w)["a"]["message"], 10, "a shown busy with the order")
            shown = robots(w)["a"]
            assert shown["state"] == "moving" and broker.url in shown["message"], shown
            await add_poi(w, "west", 4.5, Y)  # nearer a than b
            got = await dispatch(w, "west")
            # a bids not (another master's order); whether b can take it depends on where a
            # stands in the corridor meanwhile
            assert got["robot"] != "a", got
            assert "a: skipped, busy with VDA 5050 order job" in got["message"], got
            while master.last["nodeStates"]:  # a never takes the task while the order runs
                assert robots(w)["a"]["task"] == 0, robots(w)["a"]
                await w.next("/fleet/robots", timeout=10)
            link = next(x for x in w.latest("/vda5050/link")["links"] if x["robot"] == "a")
            assert link["connected"] and link["order_id"] == "job", link
    finally:
        await w.close()


async def test_a_fleet_task_refuses_a_vda_order(make_server, broker, tmp_path):
    server, w = await site(make_server, broker, tmp_path)
    try:
        await add_poi(w, "east", 16.0, Y)
        got = await dispatch(w, "east", robot="b")
        await w.until(lambda: robots(w)["b"]["task"] == got["task"], 10, "b on the task")
        async with Master(broker.port, serial="b") as master:
            here = (await master.sync())["agvPosition"]
            await master.order("mine", 0, [node("s", 0, here["x"], here["y"]),
                                           node("t", 2, here["x"] - 1.0, here["y"])])
            state = await master.state(has_error(e.ORDER, f"fleet task {got['task']}"),
                                       "the order refused for the fleet task")
            assert state["orderId"] == "" and not state["nodeStates"]
            assert robots(w)["b"]["task"] == got["task"]  # the task goes on
    finally:
        await w.close()


def move_to(x: float, y: float) -> dict:
    return {"location": {"x": x, "y": y, "z": 0.0},
            "options": {"opt_flags": {"flags": 0}, "speed_ratio": {"is_valid": False,
                                                                   "value": 0.0}},
            "yaw": 0.0}


async def test_a_console_goal_refuses_and_a_console_cancel_ends_the_order(make_server, broker):
    server = await make_server(robot="sim", vda5050=broker.url)
    w = await Watcher.open(server.port)
    try:
        async with Master(broker.port) as master:
            here = (await master.sync())["agvPosition"]
            x, y = here["x"], here["y"]
            # the console drives the robot: a VDA order is refused meanwhile
            await w.publish(f"{NS}/move_to", move_to(x + 3.0, y),
                            "slamware_ros_sdk/MoveToRequest")
            await master.state(lambda s: s["driving"], "the console's motion seen")
            await master.order("o1", 0, [node("s", 0, x, y), node("t", 2, x + 1.0, y)])
            await master.state(has_error(e.ORDER, "another client"), "refused for the console")
            await w.publish(f"{NS}/cancel_action", {}, "slamware_ros_sdk/CancelActionRequest")
            for _ in range(100):  # stopped: at rest, read afresh (a bounded number of asks)
                stopped = await master.sync()
                if not stopped["driving"] and abs(stopped["velocity"]["vx"]) < 0.01:
                    break
            else:
                raise AssertionError(f"the robot never stood still: {stopped}")
            # a VDA order, cancelled from the console on its way
            p = stopped["agvPosition"]
            await master.order("o2", 0, [node("s", 0, p["x"], p["y"]),
                                         node("t", 2, p["x"] - 3.0, p["y"])])
            await master.state(lambda s: s["orderId"] == "o2" and s["driving"], "driving o2")
            await w.publish(f"{NS}/cancel_action", {}, "slamware_ros_sdk/CancelActionRequest")
            state = await master.state(has_error(e.ORDER_CANCELLED), "the order cancelled", 20)
            assert state["orderId"] == "o2" and not state["nodeStates"] and \
                not state["edgeStates"]
            refs = next({r["referenceKey"]: r["referenceValue"] for r in err["errorReferences"]}
                        for err in state["errors"] if err["errorType"] == e.ORDER_CANCELLED)
            assert refs["orderId"] == "o2" and refs["orderUpdateId"] == "0", refs
    finally:
        await w.close()

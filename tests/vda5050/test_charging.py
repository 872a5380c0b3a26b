"""``startCharging`` on a node: the robot's go-home to its dock (the office world's), finished
once it charges; ``stopCharging`` finished at once, as the factsheet says."""

from __future__ import annotations

from tests.vda5050.master import Master, action, node


def status(state: dict, action_id: str) -> str:
    return next((a["actionStatus"] for a in state["actionStates"]
                 if a["actionId"] == action_id), "")


async def test_start_charging_on_a_node_docks_the_robot(make_server, broker):
    await make_server(robot="sim", sim_speed=4, vda5050=broker.url)
    async with Master(broker.port) as master:
        here = (await master.sync())["agvPosition"]
        assert not master.last["batteryState"]["charging"]
        await master.order("charge", 0, [node("here", 0, here["x"], here["y"], actions=[
            action("startCharging", "dock")])])
        await master.state(lambda s: status(s, "dock") == "RUNNING", "charging begun")
        state = await master.state(lambda s: status(s, "dock") == "FINISHED", "docked", 90)
        assert state["batteryState"]["charging"] and not state["nodeStates"]
        assert abs(state["agvPosition"]["x"] - 3.5) < 0.5, state["agvPosition"]
        await master.instant(action("stopCharging", "undock"))
        await master.state(lambda s: status(s, "undock") == "FINISHED", "stopCharging done")
    assert not master.invalid, master.invalid

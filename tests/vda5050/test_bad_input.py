"""Bad input on a vehicle's topics, through a real broker (mosquitto) from a plain MQTT client:
each answered with the spec's error in ``state.errors`` (or ignored where the spec says so),
while the robot keeps driving the order it had; the server's other clients are unaffected and
what the vehicle holds stays bounded."""

from __future__ import annotations

import asyncio
import time

import numpy as np

from hitrobot_server.nodes.ground.names import MAP_TOPIC
from hitrobot_server.nodes.map_manager.grids import grid_of_message
from hitrobot_server.vda5050 import errors as e
from hitrobot_server.vda5050.inbox import MAX_BYTES
from hitrobot_server.vda5050.orders import INSTANT_KEPT
from tests.helpers import WsClient, round_trip
from tests.vda5050.master import Master, action, has_error, node


async def vehicle_server(make_server, broker):
    server = await make_server(robot="sim", vda5050=broker.url)
    return server, server.vda5050.links[0][1].vehicle


async def test_bad_messages_are_answered_and_the_order_goes_on(make_server, broker):
    server, vehicle = await vehicle_server(make_server, broker)
    async with Master(broker.port) as master:
        start = (await master.sync())["agvPosition"]
        x, y = start["x"], start["y"]
        await master.order("drive", 0, [node("a", 0, x, y), node("b", 2, x + 2.0, y)])
        await master.state(lambda s: s["orderId"] == "drive" and s["driving"], "driving")

        await master.send("order", b"{this is not json")
        await master.state(has_error(e.VALIDATION, "not JSON"), "not JSON refused")
        bad = master.header("order", orderId="bad", orderUpdateId=0, nodes="none", edges=[])
        await master.send("order", bad)
        await master.state(has_error(e.VALIDATION, "nodes"), "the schema failure named")
        await master.send("order", {**master.header("order", orderId="v1", orderUpdateId=0,
                                                    nodes=[], edges=[]), "version": "1.1.0"})
        await master.state(has_error(e.VALIDATION, "version"), "the version refused")
        many = [node(f"n{i}", 2 * i, x, y) for i in range(10_000)]
        await master.order("many", 0, many)
        await master.state(has_error(e.VALIDATION, "bytes"), "10,000 nodes refused")
        await master.send("order", b'{"pad": "' + b"x" * (1024 * 1024) + b'"}')
        await master.state(has_error(e.VALIDATION, f"over the {MAX_BYTES}"), "1 MB refused")
        # ignored: another serial, and a headerId not above the last (a late repeat)
        await master.send("order", {**master.header("order", orderId="other", orderUpdateId=0,
                                                    nodes=[node("z", 0, x, y)], edges=[]),
                                    "serialNumber": "someone-else"})
        late = master.header("order", orderId="late", orderUpdateId=0,
                             nodes=[node("z", 0, x, y)], edges=[])
        await master.send("order", {**late, "headerId": 1})
        # a stale update and one not stitched at the base's end
        await master.order("drive", 0, [node("a", 0, x, y)])  # the same ids: a repeat
        state = await master.sync()
        assert state["orderId"] == "drive" and state["orderUpdateId"] == 0
        text = " ".join(err.get("errorDescription", "") for err in state["errors"])
        assert "someone-else" not in text and "late" not in text
        await master.order("drive", 1, [node("a", 0, x, y), node("c", 2, x + 1.0, y)])
        await master.state(has_error(e.ORDER_UPDATE), "an update off the base refused")

        done = await master.state(lambda s: s["lastNodeId"] == "b" and not s["nodeStates"],
                                  "the order driven to its end", 60)
        assert done["orderId"] == "drive"
        assert abs(done["agvPosition"]["x"] - (x + 2.0)) < 0.5
    assert not master.invalid, master.invalid
    assert server.vda5050.links[0][1].connected


async def test_a_node_outside_the_map_or_on_an_obstacle_has_no_route(make_server, broker):
    server, vehicle = await vehicle_server(make_server, broker)
    async with Master(broker.port) as master:
        here = (await master.sync())["agvPosition"]
        x, y = here["x"], here["y"]
        await master.order("far", 0, [node("a", 0, x, y), node("b", 2, x + 500.0, y)])
        await master.state(has_error(e.NO_ROUTE, "off the map"), "off the map")
        grid = grid_of_message(server.bus.topic(MAP_TOPIC).last.msg)
        rows, cols = np.nonzero(grid.data >= 90)
        wall = (float(grid.origin_x + (cols[0] + 0.5) * grid.resolution),
                float(grid.origin_y + (rows[0] + 0.5) * grid.resolution))
        await master.order("wall", 0, [node("a", 0, x, y), node("w", 2, *wall)])
        await master.state(has_error(e.NO_ROUTE, "obstacle"), "inside an obstacle")
        await master.order("pick", 0, [node("a", 0, x, y, actions=[action("pick", "p1")])])
        await master.state(has_error(e.ORDER, "'pick'"), "pick unsupported")
        state = await master.sync()
        assert state["orderId"] == "" and not state["nodeStates"] and not state["driving"]
    assert not master.invalid, master.invalid


async def test_a_flood_of_instant_actions_stays_bounded(make_server, broker):
    server, vehicle = await vehicle_server(make_server, broker)
    client = await WsClient.open(server.port)
    try:
        async with Master(broker.port) as master:
            await master.sync()
            t0 = time.monotonic()
            for i in range(2000):
                await master.instant(action("stateRequest", f"f{i}"),
                                     action("noSuchAction", f"u{i}"))
            sent = time.monotonic() - t0
            await round_trip(client, timeout=10)  # the bridge still answers at once
            state = await master.sync(timeout=60)
            assert len(state["actionStates"]) <= INSTANT_KEPT + 1
            assert len(state["errors"]) <= e.KEPT
            assert len(vehicle.book.actions) <= INSTANT_KEPT + 1
            assert any(err["errorType"] == e.INSTANT_ACTION and "noSuchAction" in
                       err["errorDescription"] for err in state["errors"])
            states = len(master.seen["state"])
            assert states < 2000 / 2, f"{states} states for 4000 actions in {sent:.1f} s"
        assert not master.invalid, master.invalid
    finally:
        await client.close()
    await asyncio.sleep(0)

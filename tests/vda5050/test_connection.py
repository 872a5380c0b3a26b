"""The vehicle's ``connection`` topic through a real broker: ONLINE retained (a master that
comes later reads it), OFFLINE on a clean stop, the Last Will CONNECTIONBROKEN when the server
dies; and a link that reconnects, with back-off, when the broker comes back."""

from __future__ import annotations

import asyncio

from tests.helpers import ServerProcess
from tests.vda5050.master import Master


def states(master: Master) -> list[str]:
    return [c["connectionState"] for c in master.seen.get("connection", [])]


async def test_online_retained_offline_on_stop_and_the_will_on_a_kill(broker):
    server = await asyncio.to_thread(ServerProcess, "--vda5050", broker.url,
                                     "--vda5050-serial", "r1", robot="sim")
    try:
        async with Master(broker.port, serial="r1") as master:  # ONLINE, retained, waited for
            assert states(master)[-1] == "ONLINE"
            state = await master.sync()
            assert state["serialNumber"] == "r1"
            assert master.seen["factsheet"][-1]["serialNumber"] == "r1"  # retained too
        server.proc.terminate()  # a clean stop: OFFLINE, retained
        await asyncio.to_thread(server.proc.wait, 30)
        async with Master(broker.port, serial="r1", online=False) as master:
            await master.wait(lambda: "OFFLINE" in states(master), "OFFLINE")
    finally:
        server.stop()
    server = await asyncio.to_thread(ServerProcess, "--vda5050", broker.url,
                                     "--vda5050-serial", "r1", robot="sim")
    try:
        async with Master(broker.port, serial="r1", online=False) as master:
            await master.wait(lambda: states(master)[-1:] == ["ONLINE"], "ONLINE again")
            await asyncio.to_thread(server.kill)  # no goodbye: the broker sends the Will
            await master.wait(lambda: states(master)[-1:] == ["CONNECTIONBROKEN"],
                              "the Last Will")
    finally:
        server.stop()


async def test_the_link_comes_back_with_the_broker(make_server, broker, tmp_path):
    server = await make_server(robot="sim", vda5050=broker.url)
    link = server.vda5050.links[0][1]
    async with Master(broker.port):
        pass
    broker.stop()
    for _ in range(200):  # bounded: the link notices the broker gone
        if not link.connected:
            break
        await asyncio.sleep(0.05)
    assert not link.connected and link.last_error
    restarted = await asyncio.to_thread(broker.restart)
    try:
        async with Master(restarted.port) as master:  # waits for ONLINE (retained or new)
            assert states(master)[-1] == "ONLINE"
            state = await master.sync()
            assert state["orderId"] == ""
        assert link.connected and link.last_error == ""
    finally:
        restarted.stop()

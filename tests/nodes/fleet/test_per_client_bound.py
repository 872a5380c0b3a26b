"""The fleet's bound per client (issue 37): each bridge client may have at most
``MAX_PER_CLIENT`` open tasks, whoever else uses the queue. Two real roslibpy clients against a
real server; the fleet learns who called from the bus's call context."""

from __future__ import annotations

import asyncio

import roslibpy

from hitrobot_server.nodes.fleet.dispatch import MAX_PER_CLIENT
from tests.helpers import connect_roslibpy
from tests.nodes.fleet.test_node import Y, fleet, pose


async def test_each_client_has_its_own_bound_on_open_tasks(make_server, tmp_path):
    """A client with 50 open tasks is refused the 51st with the limit named; the other client
    is still served, and the first may ask again once one of its tasks has ended."""
    server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 12.0, Y))
    first, second = await asyncio.gather(asyncio.to_thread(connect_roslibpy, server.port),
                                         asyncio.to_thread(connect_roslibpy, server.port))
    try:
        for robot in ("a", "b"):  # named tasks for robots out of service stay queued
            await w.call("/fleet/set_in_service", {"robot": robot, "in_service": False})

        async def ask(ros: roslibpy.Ros, robot: str) -> dict:
            service = roslibpy.Service(ros, "/fleet/dispatch", "hitrobot_msgs/Dispatch")
            request = roslibpy.ServiceRequest({"poi": "", "pose": pose(8.0, Y), "robot": robot})
            return dict(await asyncio.to_thread(service.call, request, timeout=20))

        # 25 for each robot: under the 50 per robot, so only the client's own bound applies
        taken = [await ask(first, "ab"[i % 2]) for i in range(MAX_PER_CLIENT)]
        assert all(t["accepted"] for t in taken), taken[-1]
        refused = await ask(first, "a")
        assert not refused["accepted"] and refused["task"] == 0, refused
        assert refused["message"].endswith(f"has {MAX_PER_CLIENT} tasks queued or running; "
                                           f"the limit per client is {MAX_PER_CLIENT}"), refused
        other = await ask(second, "a")
        assert other["accepted"], other
        cancel = await w.call("/fleet/cancel", {"task": taken[0]["task"]})
        assert cancel["values"]["success"], cancel
        again = await ask(first, "a")
        assert again["accepted"], again
    finally:
        await asyncio.gather(asyncio.to_thread(first.close), asyncio.to_thread(second.close))
        await w.close()

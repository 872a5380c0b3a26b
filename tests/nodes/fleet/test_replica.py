"""The board's copy between servers (nodes/fleet/replica.py) without a network: what a
dispatcher sends is what a follower keeps in its own state folder, mutex zones included, so a
follower that takes over has the zones the dispatcher had."""

from __future__ import annotations

import orjson

from hitrobot_server.nodes.fleet.board import Board
from hitrobot_server.nodes.fleet.replica import _apply, sections
from hitrobot_server.nodes.fleet.zones import Zone
from hitrobot_server.nodes.fleet.zoning import SECTION
from hitrobot_server.state import StateBinding, StateStore

CORRIDOR = Zone("corridor_a", "corridor", ((1.0, 1.0), (5.0, 1.0), (5.0, 2.0), (1.0, 2.0)))


async def test_the_zones_go_with_the_queue_and_are_kept_by_the_follower(tmp_path):
    leader_store, follower_store = StateStore.open(tmp_path / "a"), StateStore.open(tmp_path / "b")
    try:
        leader = Board(StateBinding(leader_store, "site"))
        leader.memory.put(SECTION, [CORRIDOR.record()])
        change = orjson.loads(orjson.dumps({"seq": 1, "base": 0, "sections": sections(leader),
                                            "history": []}))
        follower = Board(StateBinding(follower_store, "site"))
        _apply(follower, change)
        await follower.memory.durable()
        kept = [Zone.from_record(r) for r in follower.memory.get(SECTION)]
        assert kept == [CORRIDOR]

        leader.memory.put(SECTION, [])  # removed at the dispatcher: removed at the follower
        _apply(follower, {"seq": 2, "base": 1, "sections": sections(leader), "history": []})
        assert follower.memory.get(SECTION) == []
    finally:
        await leader_store.close()
        await follower_store.close()
    again = StateStore.open(tmp_path / "b")  # the follower's folder has it after a restart
    try:
        assert again.get(f"fleet/{SECTION}") == []
    finally:
        await again.close()

"""The fleet's words (issue 46, friction 7) as a client reads them on a real server with two
simulated robots: what a robot does in plain words (not ``SeriesMoveToAction``), the bids
naming each robot skipped and why, a robot the operator named not said to "finish first", and a
paused task saying what happened (not "paused (running)"). A robot waiting for a zone is tested
in test_fleet_zones.py."""

from __future__ import annotations

from hitrobot_server.nodes.fleet.member import action_words
from tests.nodes.fleet.test_node import Y, dispatch, fleet, pose, robots, task


def test_actions_in_the_operators_words():
    assert action_words("slamtec.agent.actions.SeriesMoveToAction") == "go to"
    assert action_words("slamtec.agent.actions.MoveToAction") == "go to"
    assert action_words("slamtec.agent.actions.GoHomeAction") == "go home"
    assert action_words("SweepSpotAction") == "sweep spot"
    assert action_words("Action") == "Action"


async def test_rows_bids_a_named_robot_and_a_pause_in_words(make_server, tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 14.0, Y), speed=1.0)
    try:
        off = await w.call("/fleet/set_in_service", {"robot": "b", "in_service": False})
        assert off["values"]["success"], off
        got = await dispatch(w, target=pose(9.0, Y))
        assert got["robot"] == "a", got
        bids = got["message"].split(" — bids: ")[1].split("; ")
        assert bids[0].startswith("a ") and bids[1:] == ["b: skipped, out of service"], bids
        await w.until(lambda: robots(w)["a"]["state"] == "moving", 10, "a moving")
        assert robots(w)["a"]["message"] == "go to", robots(w)["a"]
        assert all("Action" not in r["message"] for _t, m in w.messages["/fleet/robots"]
                   for r in m["robots"])
        paused = await w.call("/fleet/pause", {"task": got["task"]})
        assert paused["values"]["success"], paused
        assert task(w, got["task"])["message"] == "paused on its way: a stopped"

        away = await w.call("/fleet/set_in_service", {"robot": "a", "in_service": False})
        assert away["values"]["success"], away
        named = await dispatch(w, target=pose(6.0, Y), robot="a")
        assert named["accepted"] and named["robot"] == "", named
        head = named["message"].split(" — ")[0]
        assert head == f"task {named['task']}: queued for a (asked for)", named
        assert "finishes first" not in named["message"]
    finally:
        await w.close()

"""The sim-device answers like a Slamware robot: raw HTTP against it, no client in between."""

from __future__ import annotations

import aiohttp
import pytest

from hitrobot_server.robot.rest import mapformat, paths


@pytest.fixture
async def http(device):
    async with aiohttp.ClientSession(device.url) as session:
        yield session


async def call(http, method: str, path: str, **kw) -> tuple[int, str, bytes]:
    async with http.request(method, path, **kw) as resp:
        return resp.status, resp.content_type, await resp.read()


async def test_bare_json_values_and_content_types(http):
    status, ctype, body = await call(http, "GET", paths.QUALITY)
    assert status == 200 and ctype == "application/json" and body.isdigit()
    assert (await call(http, "GET", paths.LOCALIZATION_ENABLE))[2] == b"true"
    assert (await call(http, "PUT", paths.MAPPING_ENABLE, json={"enable": True}))[2] == b"true"
    assert (await call(http, "GET", paths.MAPPING_ENABLE))[2] == b"true"
    status, ctype, body = await call(http, "GET", paths.EXPLORE_MAP)
    assert status == 200 and ctype == "application/octet-stream"
    assert mapformat.decode(body).cells.size > 0
    status, ctype, _ = await call(http, "GET", paths.STCM)
    assert status == 200 and ctype == "application/octet-stream"


async def test_idle_current_action_is_404_and_finished_actions_are_gravestones(http, device):
    assert (await call(http, "GET", paths.CURRENT_ACTION))[0] == 404
    assert (await call(http, "DELETE", paths.CURRENT_ACTION))[0] == 200
    body = {"action_name": "slamtec.agent.actions.MoveToAction",
            "options": {"target": {"x": 6.0, "y": 8.0, "z": 0.0},
                        "move_options": {"mode": 0, "flags": ["precise"]}}}
    async with http.post(paths.ACTIONS, json=body) as resp:
        info = await resp.json()
    assert info["action_name"] == body["action_name"]
    assert info["state"] == {"status": 0, "result": 0, "reason": ""}
    async with http.get(paths.CURRENT_ACTION) as resp:
        assert resp.status == 200 and (await resp.json())["action_id"] == info["action_id"]
    await call(http, "DELETE", paths.CURRENT_ACTION)
    async with http.get(f"{paths.ACTIONS}/{info['action_id']}") as resp:
        grave = await resp.json()
    assert grave == {"action_id": info["action_id"],
                     "state": {"status": 4, "result": -2, "reason": "cancelled"}}
    assert (await call(http, "GET", f"{paths.ACTIONS}/999"))[0] == 404


@pytest.mark.parametrize("body,why", [
    ({"action_name": "slamtec.agent.actions.MoveToTagAction", "options": {}}, "unknown action"),
    ({"action_name": "MoveToAction", "options": {"target": {"x": 1, "y": 1}}}, "unknown action"),
    ({"action_name": "slamtec.agent.actions.MoveToAction", "options": {}}, "target"),
    ({"action_name": "slamtec.agent.actions.MoveToAction",
      "options": {"target": {"x": 1, "y": 1}, "move_options": {"flags": ["no_smooth"]}}},
     "unknown flag"),
    ({"action_name": "slamtec.agent.actions.MoveByAction", "options": {"direction": 4}},
     "direction"),
    ({"action_name": "slamtec.agent.actions.SeriesMoveToAction", "options": {"targets": []}},
     "targets"),
])
async def test_actions_it_cannot_create_are_400(http, body, why):
    status, _ctype, text = await call(http, "POST", paths.ACTIONS, json=body)
    assert status == 400 and b"Can not create action" in text and why.encode() in text


async def test_errors_robots_answer(http):
    assert (await call(http, "PUT", paths.POSE, json={"x": 1}))[:1] == (400,)
    assert (await call(http, "PUT", paths.POSE, data=b"{"))[0] == 400
    assert (await call(http, "DELETE", f"{paths.ROBOT_HEALTH}/123"))[0] == 400
    assert (await call(http, "GET", f"{paths.LINES}/fences"))[0] == 404
    assert (await call(http, "GET", f"{paths.RECTANGLE_AREAS}/parking"))[0] == 404
    assert (await call(http, "GET", paths.EXPLORE_MAP, params={"min_x": "1"}))[0] == 400
    assert (await call(http, "GET", paths.EXPLORE_MAP,
                       params={"min_x": "a", "min_y": "0", "max_x": "1", "max_y": "1"}))[0] == 400
    assert (await call(http, "GET", "/api/core/slam/v1/nothing"))[0] == 404


async def test_line_ids_are_chosen_by_the_robot(http):
    lines = [{"id": 77, "start": {"x": 0, "y": 0}, "end": {"x": 1, "y": 0}, "metadata": {}}]
    assert (await call(http, "POST", f"{paths.LINES}/tracks", json=lines))[2] == b"true"
    async with http.get(f"{paths.LINES}/tracks") as resp:
        stored = await resp.json()
    assert len(stored) == 1 and stored[0]["id"] != 77
    assert (await call(http, "DELETE", f"{paths.LINES}/tracks/{stored[0]['id']}"))[2] == b"true"
    assert (await call(http, "DELETE", f"{paths.LINES}/tracks/{stored[0]['id']}"))[2] == b"false"


async def test_rectangle_areas_crud_and_forbidden_ones_block(http, device):
    area = {"area": {"start": {"x": 8, "y": 7.5}, "end": {"x": 9, "y": 7.5}, "half_width": 0.5},
            "metadata": {"display_name": "x"}}
    url = f"{paths.RECTANGLE_AREAS}/forbidden_area"
    assert (await call(http, "POST", url, json=area))[2] == b"true"
    async with http.get(url) as resp:
        (stored,) = await resp.json()
    assert stored["usage"] == "forbidden_area" and stored["metadata"] == {"display_name": "x"}
    assert len(device.simulator.map.blocked) == 1
    moved = dict(area, area={**area["area"], "half_width": 0.25})
    assert (await call(http, "PUT", f"{url}/{stored['id']}", json=moved))[2] == b"true"
    assert (await call(http, "PUT", f"{url}/999", json=moved))[0] == 404
    assert (await call(http, "DELETE", f"{url}/{stored['id']}"))[2] == b"true"
    assert device.simulator.map.blocked == ()
    await call(http, "POST", f"{paths.RECTANGLE_AREAS}/coverage_area", json=area)
    assert device.simulator.map.blocked == ()  # other usages are only stored


async def test_a_paused_device_refuses_with_503_and_factories_are_listed(http, device):
    async with http.get(paths.ACTION_FACTORIES) as resp:
        names = [f["action_name"] for f in await resp.json()]
    assert "slamtec.agent.actions.GoHomeAction" in names
    await device.backend.link.stop()  # the HTTP side up, the simulator not running
    assert (await call(http, "GET", paths.POSE))[0] == 503
    await device.backend.link.start()
    assert (await call(http, "GET", paths.POSE))[0] == 200

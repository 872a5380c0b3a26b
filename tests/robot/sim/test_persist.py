"""The simulator's memory through a real state folder: what a robot keeps comes back exactly,
a bad section is skipped (and kept aside) while the others still apply."""

from __future__ import annotations

import math

from hitrobot_server.robot.model import ArtifactUsage, Line, Point2D, Pose2D
from hitrobot_server.robot.sim.backend import SimBackend
from hitrobot_server.robot.sim.persist import LINES, MAP, ROBOT, SimMemory
from hitrobot_server.robot.sim.simulator import Simulator
from hitrobot_server.state import StateStore


async def test_map_lines_home_pose_and_battery_come_back(world, tmp_path, run_until):
    store = StateStore.open(tmp_path)
    memory = SimMemory(store)
    backend = SimBackend(Simulator(world, seed=0), memory=memory)
    await backend.link.start()
    try:  # requests through the backend are on disk when they return
        await backend.maps.add_lines(ArtifactUsage.VIRTUAL_WALL,
                                [Line(0, Point2D(14.0, 2.0), Point2D(14.0, 3.0))])
        await backend.maps.set_home_pose(Pose2D(4.0, 1.0, 0.5))
    finally:
        await backend.link.stop()
    sim = backend.simulator
    sim.actions.move_to([Point2D(7.0, 8.0)])
    assert run_until(sim, lambda: math.dist((sim.pose.x, sim.pose.y), (7.0, 8.0)) < 0.2
                     and sim.actions.current_action() is None, 30)
    sim.map.clear_map()
    before = sim.saved_robot()
    await memory.sync(sim, 0.0, urgent=True)  # as the stepping task samples it
    await store.close()

    again = StateStore.open(tmp_path)
    fresh = Simulator(world, seed=0)
    done = SimMemory(again).restore(fresh)
    assert done[0] == "the robot's map" and done[1] == "1 wall, 0 tracks, home"
    assert fresh.saved_robot() == before
    assert fresh.map.known_area().is_empty  # the cleared map, not the world's prebuilt one
    assert fresh.home_pose == Pose2D(4.0, 1.0, 0.5)
    assert [(ln.start, ln.end) for ln in fresh.map.get_lines(ArtifactUsage.VIRTUAL_WALL)] == [
        (Point2D(14.0, 2.0), Point2D(14.0, 3.0))]


async def test_a_bad_section_is_skipped_and_the_others_apply(world, tmp_path):
    store = StateStore.open(tmp_path)
    store.put(ROBOT, {"pose": [0.0, 0.0, 0.0], "believed": [0.0, 0.0, 0.0], "battery": 50,
                      "localization": True})  # (0, 0) is inside the outer wall
    store.put(LINES, {"walls": [[1, 1.0, 1.0, 2.0, "x"]], "tracks": [], "home": None})
    store.put(MAP, b"not a map")
    await store.close()
    again = StateStore.open(tmp_path)
    sim = Simulator(world, seed=0)
    assert SimMemory(again).restore(sim) == []
    assert sim.saved_robot()["pose"] == [5.0, 8.0, 0.0]  # the world's start pose
    skipped = " ".join(again.restored.skipped)
    assert "inside an obstacle" in skipped and "'sim/lines' skipped" in skipped
    assert "'sim/map' skipped" in skipped
    assert len(list((tmp_path / "set-aside").iterdir())) == 3

"""What roslibpy's own suite needs of a server run with ``--demo-services`` (issue 49): an
identity transform for a frame looked up in itself, and a ``/fibonacci`` paced like the ROS 2
tutorial (one term a second) so the suite's cancel, 3 s after its goal, finds it running. The
real roslibpy against a real server process."""

from __future__ import annotations

import threading
import time

import pytest
import roslibpy
import roslibpy.tf

from tests.helpers import ServerProcess, connect_roslibpy


@pytest.fixture(scope="module")
def demo_process():
    proc = ServerProcess("--demo-services")
    yield proc
    proc.stop()


@pytest.fixture
def ros(demo_process):
    r = connect_roslibpy(demo_process.port)
    yield r
    r.close()


def test_a_frame_in_itself_is_the_identity(ros):
    """roslibpy's TF test: ``world`` in ``world``, a frame no one publishes."""
    tf = roslibpy.tf.TFClient(ros, fixed_frame="world", rate=10.0)
    seen: list[dict] = []
    got = threading.Event()
    tf.subscribe("world", lambda t: (seen.append(t), got.set()))
    assert got.wait(10)
    assert seen[0]["translation"] == {"x": 0.0, "y": 0.0, "z": 0.0}
    assert seen[0]["rotation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def test_fibonacci_runs_at_one_term_a_second(ros):
    """An order-8 goal lasts about 8 s: measured, its third term comes 2 s after its first, and
    a cancel then still finds it running."""
    client = roslibpy.ActionClient(ros, "/fibonacci", "example_interfaces/action/Fibonacci")
    stamps: list[float] = []
    third = threading.Event()
    results: list[dict] = []
    done = threading.Event()

    def feedback(_f: dict) -> None:
        stamps.append(time.monotonic())
        if len(stamps) >= 3:
            third.set()

    goal_id = client.send_goal(roslibpy.Goal({"order": 8}),
                               lambda r: (results.append(r), done.set()), feedback,
                               lambda r: (results.append(r), done.set()))
    assert third.wait(15)
    assert stamps[2] - stamps[0] >= 1.8  # (a busy machine only makes it slower)
    client.cancel_goal(goal_id)
    assert done.wait(10)
    assert results[0]["status"] == roslibpy.GoalStatus.CANCELED
    assert len(results[0]["values"]["sequence"]) < 10

"""The transform tree: composition along chains, inverses, stamps, and what is not connected."""

from __future__ import annotations

import math

import pytest

from hitrobot_server.tf_buffer import TFBuffer, Transform


def stamped(parent: str, child: str, x: float, y: float, yaw: float, t: float) -> dict:
    secs = int(t)
    return {"header": {"seq": 0, "stamp": {"secs": secs, "nsecs": int((t - secs) * 1e9)},
                       "frame_id": parent},
            "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": y, "z": 0.0},
                          "rotation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2),
                                       "w": math.cos(yaw / 2)}}}


def yaw(t: Transform) -> float:
    x, y, z, w = t.rotation
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def test_chain_composes_and_takes_the_oldest_stamp():
    buf = TFBuffer()
    buf.add(stamped("/map", "/odom", 1.0, 0.0, math.pi / 2, 100.0))
    buf.add(stamped("odom", "base_link", 2.0, 0.0, 0.0, 100.5))
    buf.add(stamped("base_link", "laser", 0.1, 0.0, 0.0, 100.2))
    found = buf.lookup("map", "/laser")
    assert found.translation == pytest.approx((1.0, 2.1, 0.0))
    assert yaw(found) == pytest.approx(math.pi / 2)
    assert found.stamp == pytest.approx(100.0)


def test_lookup_between_branches_uses_the_inverse():
    buf = TFBuffer()
    buf.add(stamped("map", "base_link", 3.0, 1.0, math.pi / 2, 5.0))
    buf.add(stamped("map", "dock", 3.0, 4.0, 0.0, 6.0))
    found = buf.lookup("base_link", "dock")  # the dock seen from the robot: 3 m straight ahead
    assert found.translation == pytest.approx((3.0, 0.0, 0.0), abs=1e-9)
    assert yaw(found) == pytest.approx(-math.pi / 2)
    back = buf.lookup("dock", "base_link")
    assert (found * back).translation == pytest.approx((0, 0, 0), abs=1e-9)


def test_latest_transform_replaces_the_previous_one_and_a_frame_to_itself_is_identity():
    buf = TFBuffer()
    buf.add(stamped("map", "base_link", 1.0, 0.0, 0.0, 1.0))
    buf.add(stamped("map", "base_link", 2.0, 0.0, 0.0, 2.0))
    assert buf.lookup("map", "base_link").translation == pytest.approx((2.0, 0.0, 0.0))
    assert buf.lookup("map", "map").translation == (0.0, 0.0, 0.0)


def test_unconnected_unknown_and_looping_frames_are_not_found():
    buf = TFBuffer()
    buf.add(stamped("map", "a", 1.0, 0.0, 0.0, 1.0))
    buf.add(stamped("world", "b", 1.0, 0.0, 0.0, 1.0))
    assert buf.lookup("map", "b") is None
    assert buf.lookup("map", "nowhere") is None
    buf.add(stamped("c", "d", 0.0, 0.0, 0.0, 1.0))
    buf.add(stamped("d", "c", 0.0, 0.0, 0.0, 1.0))
    assert buf.lookup("c", "map") is None
    buf.add(stamped("e", "e", 0.0, 0.0, 0.0, 1.0))  # a frame as its own parent is ignored
    assert "e" not in buf.frames()


def test_distance_and_angle_between_transforms():
    a = Transform((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    b = Transform((3.0, 4.0, 0.0), (0.0, 0.0, math.sin(0.25), math.cos(0.25)))
    assert a.distance_to(b) == pytest.approx(5.0)
    assert a.angle_to(b) == pytest.approx(0.5)
    flipped = Transform((0, 0, 0), tuple(-c for c in b.rotation))  # q and -q: same rotation
    assert flipped.angle_to(b) == pytest.approx(0.0, abs=1e-6)

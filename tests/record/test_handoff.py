"""The hand-off's bytes (sans-I/O): what the loop's :class:`BatchBuilder` makes, the writer's
:func:`read_batch` reads back as the same messages, with the topics named once."""

from __future__ import annotations

import numpy as np

from hitrobot_server.record.handoff import CDR, JSON, MSG, BatchBuilder, Item, read_batch


def _blob(builder: BatchBuilder) -> tuple[bytes, int]:
    parts, size = builder.take()
    return b"".join(parts), size


def test_a_batch_reads_back_as_its_messages_in_order():
    import pickle

    grid = {"data": np.arange(6, dtype=np.int8), "info": {"width": 3}}
    b = BatchBuilder()
    b.define(0, "/scan", "sensor_msgs/LaserScan")
    b.add(0, CDR, False, 10, 9, 1, b"\x00\x01\x00\x00scan", 300)
    b.define(1, "/map", "nav_msgs/OccupancyGrid")
    b.add(1, MSG, True, 11, 11, 7, pickle.dumps(grid), 400)
    b.add(0, JSON, False, 2**62, 2**62 - 1, 2**40, b'{"op":"publish"}', 50)
    b.add(0, CDR, False, 12, 12, 2, b"", 256)  # an empty message is still a message
    blob, size = _blob(b)
    assert size == 300 + 400 + 50 + 256

    topics: dict[int, tuple[str, str]] = {}
    items, counted = read_batch(blob, topics)
    assert counted == size
    assert topics == {0: ("/scan", "sensor_msgs/LaserScan"), 1: ("/map", "nav_msgs/OccupancyGrid")}
    assert items[0] == Item("/scan", "sensor_msgs/LaserScan", False, 10, 9, 1, CDR,
                            b"\x00\x01\x00\x00scan")
    assert items[1][:7] == ("/map", "nav_msgs/OccupancyGrid", True, 11, 11, 7, MSG)
    assert items[1].data["info"] == {"width": 3}
    assert items[1].data["data"].tolist() == [0, 1, 2, 3, 4, 5]
    assert items[2] == Item("/scan", "sensor_msgs/LaserScan", False, 2**62, 2**62 - 1, 2**40,
                            JSON, b'{"op":"publish"}')
    assert items[3].data == b"" and items[3].seq == 2
    assert len(items) == 4


def test_topics_named_in_one_batch_serve_the_next_and_the_builder_empties():
    b = BatchBuilder()
    b.define(5, "/odom", "nav_msgs/Odometry")
    b.add(5, CDR, False, 1, 1, 1, b"a", 257)
    topics: dict[int, tuple[str, str]] = {}
    read_batch(_blob(b)[0], topics)
    assert b.parts == [] and b.size == 0

    b.add(5, CDR, False, 2, 2, 2, b"bb", 258)
    items, _ = read_batch(_blob(b)[0], topics)
    assert [(i.topic, i.data) for i in items] == [("/odom", b"bb")]


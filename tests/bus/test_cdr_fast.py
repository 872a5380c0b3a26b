"""The codec's direct CDR writer (hitrobot_server/bus/cdr_encode.py) makes rosbags' own bytes.

The reference is rosbags' ``serialize_cdr`` of the rosbags object the codec builds from the same
canonical message (``Ros2Codec.wrap``: the path every CDR took before). The direct writer is
called by itself, so a message it could not write would fail here rather than fall back."""

from __future__ import annotations

import random
import string

import numpy as np
import pytest

from hitrobot_server.bus.cdr import Ros2Codec
from hitrobot_server.bus.cdr_encode import DirectEncoder
from hitrobot_server.types.registry import MsgType, TypeRegistry

RANGES = {"bool": (0, 1), "int8": (-128, 127), "byte": (-128, 127), "uint8": (0, 255),
          "char": (0, 255), "int16": (-2**15, 2**15 - 1), "uint16": (0, 2**16 - 1),
          "int32": (-2**31, 2**31 - 1), "uint32": (0, 2**32 - 1),
          "int64": (-2**63, 2**63 - 1), "uint64": (0, 2**64 - 1)}


@pytest.fixture(scope="module")
def codec() -> Ros2Codec:
    return Ros2Codec(TypeRegistry.default())


@pytest.fixture(scope="module")
def direct(codec) -> DirectEncoder:
    return DirectEncoder(lambda name: codec.store.fielddefs[name][1])


def reference(codec: Ros2Codec, msg: dict, mtype: MsgType) -> bytes:
    return bytes(codec.store.serialize_cdr(codec.wrap(msg, mtype), mtype.name))


def fast(codec: Ros2Codec, direct: DirectEncoder, msg: dict, mtype: MsgType) -> bytes:
    codec.definition(mtype.name)  # the type and those it uses, in the ROS 2 store
    encode = direct.encoder(mtype.name)
    assert encode is not None, mtype.name
    return encode(msg)


def value(rng: random.Random, typ: str) -> object:
    if typ in ("float32", "float64"):
        return rng.choice([0.0, -0.0, 1.5, rng.uniform(-1e6, 1e6), float("inf"), float("nan")])
    if typ == "string":
        return "".join(rng.choice(string.ascii_letters + "é€ 😀") for _ in range(rng.randrange(9)))
    if typ in ("time", "duration"):
        return {"secs": rng.randrange(2**31), "nsecs": rng.randrange(10**9)}
    low, high = RANGES[typ]
    v = rng.randint(low, high)
    return bool(v) if typ == "bool" else v


def array(rng: random.Random, typ: str, length: int) -> object:
    items = [value(rng, typ) for _ in range(length)]
    if typ in ("string", "time", "duration") or rng.random() < 0.5:
        return items
    if typ in ("uint8", "char") and rng.random() < 0.5:
        return bytes(items)
    return np.asarray(items, dtype="float32" if typ == "float32" else None)


def message(rng: random.Random, reg: TypeRegistry, mtype: MsgType, depth: int = 0) -> dict:
    """A random canonical message: some fields left out (zero), arrays of 0 to 4 elements as
    lists, numpy arrays or bytes."""
    msg: dict = {}
    for f in mtype.fields:
        if rng.random() < 0.15:
            continue  # missing: the codec writes its zero
        length = f.array or rng.randrange(5) if f.array is not None else None
        if f.is_msg:
            sub = reg.msg(f.type)
            if length is None:
                msg[f.name] = message(rng, reg, sub, depth + 1)
            else:
                msg[f.name] = [message(rng, reg, sub, depth + 1) for _ in range(length)]
        elif length is None:
            msg[f.name] = value(rng, f.type)
        else:
            msg[f.name] = array(rng, f.type, length)
    return msg


def test_every_type_is_written_as_rosbags_writes_it(codec, direct):
    """All our message types (the services' and actions' parts too), three random messages
    each: the same bytes, through the direct writer alone and through ``encode``."""
    reg = codec.types
    rng = random.Random(33)
    names = reg.msg_names()
    assert len(names) > 300
    for name in names:
        mtype = reg.msg(name)
        for _ in range(3):
            msg = message(rng, reg, mtype)
            expected = reference(codec, msg, mtype)
            assert fast(codec, direct, msg, mtype) == expected, (name, msg)
            assert codec.encode(msg, mtype) == expected, name


def scan(ranges: object) -> dict:
    return {"header": {"seq": 9, "stamp": {"secs": 1_700_000_000, "nsecs": 5},
                       "frame_id": "laser"},
            "angle_min": -3.14, "angle_max": 3.14, "angle_increment": 0.0087,
            "time_increment": 0.0, "scan_time": 0.1, "range_min": 0.1, "range_max": 30.0,
            "ranges": ranges, "intensities": []}


@pytest.mark.parametrize("ranges", [
    [float(x) for x in np.random.default_rng(1).uniform(0.1, 30.0, 720).astype(np.float32)],
    [1.0, None, 2.5, float("inf")],  # a client's null range: NaN
    [1, 2, 3],  # integers in a float array
    [1e39],  # beyond float32: inf, as numpy converts it
    np.linspace(0, 10, 720),  # float64 numpy from a node
    [],
])
def test_laserscan(codec, direct, ranges):
    mtype = codec.types.msg("sensor_msgs/LaserScan")
    msg = scan(ranges)
    assert fast(codec, direct, msg, mtype) == reference(codec, msg, mtype)


def test_image_grid_cloud_and_nested(codec, direct):
    """Big byte and int8 arrays as a node hands them (bytes, numpy), odd string lengths before
    aligned fields, and a nested message with arrays of messages (Path, MarkerArray)."""
    reg = codec.types
    rng = np.random.default_rng(2)
    header = {"stamp": {"secs": 3, "nsecs": 4}, "frame_id": "cam"}
    cases = {
        "sensor_msgs/Image": {"header": header, "height": 48, "width": 64, "encoding": "rgb8",
                              "is_bigendian": 0, "step": 192,
                              "data": rng.integers(0, 256, 48 * 192, dtype=np.uint8).tobytes()},
        "nav_msgs/OccupancyGrid": {
            "header": header, "info": {"map_load_time": {"secs": 1, "nsecs": 2},
                                       "resolution": 0.05, "width": 30, "height": 20,
                                       "origin": {"position": {"x": -1.0, "y": 2.0, "z": 0.0},
                                                  "orientation": {"w": 1.0}}},
            "data": rng.integers(-1, 101, 600, dtype=np.int8)},
        "sensor_msgs/PointCloud2": {
            "header": header, "height": 1, "width": 3,
            "fields": [{"name": n, "offset": 4 * i, "datatype": 7, "count": 1}
                       for i, n in enumerate("xyz")],
            "is_bigendian": False, "point_step": 12, "row_step": 36,
            "data": list(rng.integers(0, 256, 36)), "is_dense": True},
        "nav_msgs/Path": {"header": header, "poses": [
            {"header": {"frame_id": "m" * k}, "pose": {"position": {"x": float(k)}}}
            for k in range(4)]},
        "visualization_msgs/MarkerArray": {"markers": [
            {"header": header, "ns": "a", "id": 1, "points": [{"x": 1.0}, {"y": 2.0}],
             "colors": [{"r": 0.5, "a": 1.0}], "text": "é", "lifetime": {"secs": 1}}]},
    }
    for name, msg in cases.items():
        mtype = reg.msg(name)
        assert fast(codec, direct, msg, mtype) == reference(codec, msg, mtype), name


def test_a_bad_value_fails_as_the_reference_does(codec):
    """A value neither path can write raises the reference's error from ``encode``."""
    mtype = codec.types.msg("sensor_msgs/LaserScan")
    for bad in (scan(["x"]), scan([[1.0, 2.0]]), {**scan([]), "angle_min": "wide"}):
        with pytest.raises(Exception) as expected:
            reference(codec, bad, mtype)
        with pytest.raises(expected.type):
            codec.encode(bad, mtype)

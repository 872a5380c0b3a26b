"""Outgoing fragmentation and bounded, per-client reassembly of incoming fragments."""

import orjson
import pytest

from hitrobot_server.protocol.errors import ProtocolError
from hitrobot_server.protocol.fragment import (
    FRAGMENT_OVERHEAD,
    MAX_FRAGMENTS,
    MIN_FRAGMENT_SIZE,
    Defragmenter,
    FragmentBudget,
    FragmentIds,
    fragment,
    fragment_bytes,
    fragment_size_for,
)
from hitrobot_server.session.rosbridge.frames import fragments

PAYLOAD = '{"op":"publish","topic":"/chatter","msg":{"data":"hello world"}}'


def frag(id="m", data="x", num=0, total=2):
    return {"op": "fragment", "id": id, "data": data, "num": num, "total": total}


# --- outgoing ---------------------------------------------------------------------------


@pytest.mark.parametrize("size", [1, 7, 10, len(PAYLOAD) - 1, len(PAYLOAD), 1000])
def test_fragment_slices_into_numbered_chunks(size):
    ops = fragment(PAYLOAD, size, "fragment:1")
    expected_total = -(-len(PAYLOAD) // size)
    assert len(ops) == expected_total
    assert "".join(op["data"] for op in ops) == PAYLOAD
    for num, op in enumerate(ops):
        assert op == {
            "op": "fragment",
            "id": "fragment:1",
            "data": PAYLOAD[num * size : (num + 1) * size],
            "num": num,
            "total": expected_total,
        }
        assert type(op["total"]) is int


def test_fragment_counts_characters_not_bytes():
    ops = fragment("é中😀ab", 1, "f")
    assert [op["data"] for op in ops] == ["é", "中", "😀", "a", "b"]


def test_fragment_rejects_non_positive_size():
    with pytest.raises(ValueError, match="at least 1"):
        fragment(PAYLOAD, 0, "f")


def test_fragment_bytes_are_the_encoded_ops():
    text = '{"data":"é\\"中"}'
    frames = fragment_bytes(text, 4, "fragment:9")
    assert [orjson.loads(frame) for frame in frames] == fragment(text, 4, "fragment:9")


def test_fragment_ids_are_unique_and_non_empty():
    ids = FragmentIds()
    made = [ids.next(), ids.next(), ids.next("call_service:/x:1"), ids.next(0), ids.next()]
    assert len(set(made)) == len(made)
    assert all(isinstance(i, str) and i for i in made)
    assert made[2].endswith(":call_service:/x:1")


def test_outgoing_fragments_reassemble():
    defrag = Defragmenter()
    results = [defrag.add(op, 0.0) for op in fragment(PAYLOAD, 5, "fragment:1")]
    assert results[:-1] == [None] * (len(results) - 1)
    assert results[-1] == PAYLOAD
    assert defrag.pending == 0 and defrag.buffered == 0


# --- incoming ---------------------------------------------------------------------------


def test_joins_by_num_not_arrival_order():
    ops = fragment(PAYLOAD, 6, "m")
    order = [3, 0, len(ops) - 1, *range(4, len(ops) - 1), 2, 1]
    defrag = Defragmenter()
    results = [defrag.add(ops[i], 1.0) for i in order]
    assert results[-1] == PAYLOAD
    assert all(r is None for r in results[:-1])


def test_single_fragment_message_completes_at_once():
    defrag = Defragmenter()
    assert defrag.add(frag(data="{}", total=1), 0.0) == "{}"
    assert defrag.pending == 0


def test_messages_with_different_ids_are_independent():
    defrag = Defragmenter()
    assert defrag.add(frag(id="a", data="A0"), 0.0) is None
    assert defrag.add(frag(id=7, data="B0"), 0.0) is None
    assert defrag.add(frag(id="7", data="C1", num=1), 0.0) is None  # "7" is not 7
    assert defrag.add(frag(id=7, data="B1", num=1), 0.0) == "B0B1"
    assert defrag.add(frag(id="a", data="A1", num=1), 0.0) == "A0A1"
    assert defrag.pending == 1


def test_fragment_text_may_itself_be_a_fragment_op():
    inner = orjson.dumps(frag(id="inner", data="{}", total=1)).decode()
    defrag = Defragmenter()
    joined = None
    for op in fragment(inner, 8, "outer"):
        joined = defrag.add(op, 0.0)
    assert defrag.add(orjson.loads(joined), 0.0) == "{}"


@pytest.mark.parametrize(
    ("op", "field"),
    [
        ({"op": "fragment", "data": "x", "num": 0, "total": 2}, "id"),
        (frag(id=True), "id"),
        (frag(id={"a": 1}), "id"),
        (frag(data=None), "data"),
        (frag(data=3), "data"),
        (frag(num="0"), "num"),
        (frag(num=0.0), "num"),
        (frag(num=False), "num"),
        (frag(total=2.0), "total"),
        (frag(total=0), "total"),
        (frag(num=-1), "num"),
        (frag(num=2, total=2), "num"),
        ({"op": "fragment", "id": "m", "data": "x", "total": 2}, "num"),
    ],
)
def test_invalid_fragments_name_the_field(op, field):
    defrag = Defragmenter()
    with pytest.raises(ProtocolError) as info:
        defrag.add(op, 0.0)
    assert f"'{field}'" in info.value.msg
    assert info.value.msg.startswith("fragment:")
    assert defrag.pending == 0


def test_error_carries_the_fragment_id():
    with pytest.raises(ProtocolError) as info:
        Defragmenter().add(frag(id="abc", num=5), 0.0)
    assert info.value.id == "abc"


def test_duplicate_num_is_rejected_but_message_survives():
    defrag = Defragmenter()
    defrag.add(frag(data="A", num=0, total=3), 0.0)
    with pytest.raises(ProtocolError, match="'num' 0 was already received"):
        defrag.add(frag(data="Z", num=0, total=3), 0.0)
    defrag.add(frag(data="B", num=1, total=3), 0.0)
    assert defrag.add(frag(data="C", num=2, total=3), 0.0) == "ABC"


def test_total_must_agree_with_earlier_fragments():
    defrag = Defragmenter()
    defrag.add(frag(data="A", num=0, total=3), 0.0)
    with pytest.raises(ProtocolError, match="'total' is 4 but earlier fragments .* said 3"):
        defrag.add(frag(data="B", num=1, total=4), 0.0)
    defrag.add(frag(data="B", num=1, total=3), 0.0)
    assert defrag.add(frag(data="C", num=2, total=3), 0.0) == "ABC"


def test_max_bytes_drops_the_message():
    defrag = Defragmenter(max_bytes=2 * (10 + FRAGMENT_OVERHEAD))
    defrag.add(frag(id="keep", data="k" * 10, num=0, total=2), 0.0)
    defrag.add(frag(id="big", data="b" * 10, num=0, total=3), 0.0)
    with pytest.raises(ProtocolError, match="buffer limit") as info:
        defrag.add(frag(id="big", data="b" * 10, num=1, total=3), 0.0)
    assert info.value.id == "big"
    assert defrag.pending == 1
    assert defrag.buffered == 10 + FRAGMENT_OVERHEAD
    # The other message is unaffected, and the dropped id starts fresh.
    assert defrag.add(frag(id="keep", data="k", num=1, total=2), 0.0) == "k" * 10 + "k"
    assert defrag.add(frag(id="big", data="2", num=2, total=3), 0.0) is None
    assert defrag.pending == 1


def test_many_tiny_fragments_are_bounded_too():
    defrag = Defragmenter(max_bytes=100 * FRAGMENT_OVERHEAD)
    with pytest.raises(ProtocolError, match="buffer limit"):
        for num in range(1000):
            defrag.add(frag(data="", num=num, total=1000), 0.0)
    assert defrag.buffered == 0


def test_max_messages_bounds_concurrent_ids():
    defrag = Defragmenter(max_messages=2)
    defrag.add(frag(id="a"), 0.0)
    defrag.add(frag(id="b"), 0.0)
    with pytest.raises(ProtocolError, match="too many fragmented messages") as info:
        defrag.add(frag(id="c"), 0.0)
    assert info.value.id == "c"
    assert defrag.pending == 2
    assert defrag.add(frag(id="a", num=1), 0.0) == "xx"
    assert defrag.add(frag(id="c"), 0.0) is None


def test_max_total_rejects_and_drops():
    defrag = Defragmenter(max_total=10)
    defrag.add(frag(id="m", num=0, total=10), 0.0)
    with pytest.raises(ProtocolError, match="'total' is 11, more than the limit of 10"):
        defrag.add(frag(id="m", num=1, total=11), 0.0)
    assert defrag.pending == 0 and defrag.buffered == 0


def test_stale_messages_are_evicted_on_add():
    defrag = Defragmenter(fragment_timeout=10.0)
    defrag.add(frag(id="old", data="o"), 0.0)
    defrag.add(frag(id="new", data="n"), 5.0)
    defrag.add(frag(id="other", data="x"), 10.5)  # "old" idle 10.5 s > 10 s
    assert defrag.pending == 2
    # The evicted id starts fresh: its second half alone does not complete it.
    assert defrag.add(frag(id="old", data="O", num=1), 11.0) is None
    assert defrag.add(frag(id="new", data="N", num=1), 11.0) == "nN"


def test_expire_reports_evicted_ids_and_activity_refreshes():
    defrag = Defragmenter(fragment_timeout=10.0)
    defrag.add(frag(id="a", num=0, total=3), 0.0)
    defrag.add(frag(id="b", num=0, total=3), 1.0)
    defrag.add(frag(id="a", num=1, total=3), 8.0)  # refreshes "a"
    assert defrag.expire(10.0) == []
    assert defrag.expire(11.5) == ["b"]
    assert defrag.expire(18.5) == ["a"]
    assert defrag.pending == 0 and defrag.buffered == 0


def test_budget_is_shared_by_all_clients_and_returned_on_clear():
    budget = FragmentBudget(3 * (100 + FRAGMENT_OVERHEAD))
    a, b = Defragmenter(budget=budget), Defragmenter(budget=budget)
    a.add(frag(id="a", data="x" * 100), 0.0)
    a.add(frag(id="a2", data="x" * 100), 0.0)
    b.add(frag(id="b", data="y" * 100), 0.0)
    assert budget.used == 3 * (100 + FRAGMENT_OVERHEAD)
    with pytest.raises(ProtocolError, match="all clients together") as info:
        b.add(frag(id="b2", data="y" * 100), 0.0)
    assert info.value.id == "b2" and b.pending == 1
    a.clear()  # the client went away: its bytes are free for the others at once
    assert a.pending == 0 and budget.used == 100 + FRAGMENT_OVERHEAD
    b.add(frag(id="b2", data="y" * 100), 0.0)
    assert b.add(frag(id="b", data="Y", num=1), 0.0) == "y" * 100 + "Y"
    assert budget.used == b.buffered == 100 + FRAGMENT_OVERHEAD


def test_next_expiry_is_the_least_recently_fed_message():
    defrag = Defragmenter(fragment_timeout=10.0)
    assert defrag.next_expiry() is None
    defrag.add(frag(id="a", num=0, total=3), 1.0)
    defrag.add(frag(id="b", num=0, total=3), 2.0)
    assert defrag.next_expiry() == 11.0
    defrag.add(frag(id="a", num=1, total=3), 5.0)
    assert defrag.next_expiry() == 12.0


# --- outgoing bounds ----------------------------------------------------------------------


@pytest.mark.parametrize(("length", "requested", "used"), [
    (365_000, 1, MIN_FRAGMENT_SIZE),
    (365_000, 5000, 5000),
    (MIN_FRAGMENT_SIZE * MAX_FRAGMENTS * 3, 1, MIN_FRAGMENT_SIZE * 3),
    (MIN_FRAGMENT_SIZE * MAX_FRAGMENTS * 3 + 1, 2000, MIN_FRAGMENT_SIZE * 3 + 1),
])
def test_fragment_size_is_floored_and_frames_per_message_are_bounded(length, requested, used):
    assert fragment_size_for(length, requested) == used
    assert -(-length // used) <= MAX_FRAGMENTS


def test_a_text_cut_with_fragment_size_1_keeps_its_frame_count_bounded():
    text = orjson.dumps({"op": "publish", "topic": "/map", "msg": {"data": "x" * 365_000}})
    frames = fragments(text, 1, "fragment:1")
    ops = [orjson.loads(data) for data, _binary in frames]
    assert len(ops) == -(-len(text) // MIN_FRAGMENT_SIZE)
    assert all(len(op["data"]) <= MIN_FRAGMENT_SIZE for op in ops)
    assert "".join(op["data"] for op in ops).encode() == text

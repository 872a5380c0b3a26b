"""The state store on real files: restores, set-aside of bad files, compaction, and the
prefix property of the journal at every possible cut."""

from __future__ import annotations

import json
import logging

import pytest

from hitrobot_server.state import StateStore, identity_folder
from hitrobot_server.state.journal import decode_snapshot, encode_snapshot
from hitrobot_server.state.store import JOURNAL, SNAPSHOT


async def filled(path, changes: list[dict], compact_bytes: int = 1 << 20) -> StateStore:
    store = await_open(path, compact_bytes)
    for batch in changes:
        for key, value in batch.items():
            store.put(key, value)
        await store.flush()
    return store


def await_open(path, compact_bytes: int = 1 << 20, fresh: bool = False) -> StateStore:
    return StateStore.open(path, fresh=fresh, compact_bytes=compact_bytes)


def aside(path) -> list[str]:
    folder = path / "set-aside"
    return sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []


async def test_values_and_blobs_come_back_and_deletes_stay_deleted(tmp_path):
    store = await filled(tmp_path, [{"a": [1, 2], "map": b"\x00\x01" * 1000},
                                    {"b": {"x": 1.5}}, {"a": None}])
    assert store.writes == 3 and store.last_write is not None
    await store.close()
    again = await_open(tmp_path)
    assert again.get("a") is None and again.get("b") == {"x": 1.5}
    assert again.get("map") == b"\x00\x01" * 1000
    assert not again.restored.fresh and again.restored.skipped == []


async def test_a_burst_is_coalesced_and_every_put_waits_for_its_write(tmp_path):
    store = await_open(tmp_path)
    futures = [store.put("map", bytes([i]) * 100_000) for i in range(100)]
    await store.flush()
    assert all(f.done() and f.exception() is None for f in futures)
    assert store.writes < 100  # one write covers every change made while the last ran
    assert len(list((tmp_path / "blobs").iterdir())) <= store.writes
    await store.close()
    assert await_open(tmp_path).get("map") == bytes([99]) * 100_000


async def test_compaction_writes_a_snapshot_and_drops_old_blobs(tmp_path):
    store = await filled(tmp_path, [{"k": i, "map": bytes([i % 3]) * 10} for i in range(200)],
                         compact_bytes=2000)
    await store.close()
    assert (tmp_path / JOURNAL).stat().st_size < 2000
    seq, sections, edited = decode_snapshot((tmp_path / SNAPSHOT).read_bytes())
    assert seq >= 150 and not edited
    again = await_open(tmp_path)  # compacts at open
    assert again.get("k") == 199 and again.get("map") == bytes([199 % 3]) * 10
    assert len(list((tmp_path / "blobs").iterdir())) == 1  # only the live map's blob


async def test_every_cut_of_the_journal_is_a_prefix_of_the_batches(tmp_path):
    """A crash can stop the journal at any byte: what is read back is always the state after
    some number of whole batches, never a torn or reordered one."""
    batches = [{f"poi{i}": i, "count": i} for i in range(30)]
    store = await filled(tmp_path / "src", batches)
    await store.close()
    journal = (tmp_path / "src" / JOURNAL).read_bytes()
    snapshot = (tmp_path / "src" / SNAPSHOT).read_bytes()
    states = [{}]
    for batch in batches:
        states.append({**states[-1], **batch})
    seen = set()
    for cut in range(0, len(journal) + 1, max(1, len(journal) // 50)):
        folder = tmp_path / f"cut{cut}"
        folder.mkdir()
        (folder / SNAPSHOT).write_bytes(snapshot)
        (folder / JOURNAL).write_bytes(journal[:cut])
        opened = await_open(folder)  # one store at a time holds a folder (its lock)
        got = {k: opened.get(k) for k in states[-1]}
        await opened.close()
        got = {k: v for k, v in got.items() if v is not None}
        assert got in states, cut
        seen.add(states.index(got))
    assert len(seen) > 20  # the cuts really landed all along the journal


@pytest.mark.parametrize("damage", ["truncated", "flipped"])
async def test_a_damaged_journal_keeps_its_good_prefix_and_sets_the_rest_aside(
        tmp_path, caplog, damage):
    caplog.set_level(logging.INFO, logger="hitrobot_server.state")
    store = await filled(tmp_path, [{"a": 1}, {"b": 2}, {"c": 3}])
    await store.close()
    # the store compacted at open; write three batches after a fresh open
    store = await filled(tmp_path, [{"d": 4}, {"e": 5}, {"f": 6}])
    await store.close()
    data = (tmp_path / JOURNAL).read_bytes()
    lines = data.splitlines(keepends=True)
    if damage == "truncated":
        broken = lines[0] + lines[1] + lines[2][:10]
    else:
        middle = bytearray(lines[1])
        middle[-5] ^= 0x01
        broken = lines[0] + bytes(middle) + lines[2]
    (tmp_path / JOURNAL).write_bytes(broken)
    again = await_open(tmp_path)
    assert [again.get(k) for k in "abcdef"] == [1, 2, 3, 4] + (
        [5, None] if damage == "truncated" else [None, None])
    assert any(name.startswith("journal.log.tail") for name in aside(tmp_path))
    kind = "unfinished last record" if damage == "truncated" else "damaged record"
    assert any(kind in text for text in again.restored.skipped)
    assert kind in caplog.text


@pytest.mark.parametrize("content,why", [
    (b"robot:\n  walls: []\n", "not JSON"),
    (json.dumps({"some": "other program"}).encode(), "not a hitrobot-server state"),
    (json.dumps({"format": "hitrobot-server state", "version": 99, "seq": 1,
                 "sections": {}}).encode(), "newer than ours"),
])
async def test_an_unusable_snapshot_is_moved_aside_and_the_journal_still_read(
        tmp_path, content, why):
    store = await filled(tmp_path, [{"a": 1}])  # journal: seq 1 after the empty snapshot
    await store.close()
    (tmp_path / SNAPSHOT).write_bytes(content)
    again = await_open(tmp_path)
    assert again.get("a") == 1
    assert any(why in text for text in again.restored.skipped)
    moved = [n for n in aside(tmp_path) if n.startswith("snapshot.json.bad")]
    assert len(moved) == 1 and (tmp_path / "set-aside" / moved[0]).read_bytes() == content
    # the new snapshot is good and holds what could be read
    assert decode_snapshot((tmp_path / SNAPSHOT).read_bytes())[1] == {"a": 1}


async def test_a_hand_edited_snapshot_is_read_and_the_original_kept(tmp_path):
    store = await filled(tmp_path, [{"name": "old"}])
    await store.close()
    await await_open(tmp_path).close()  # compacts the journal into the snapshot
    doc = json.loads((tmp_path / SNAPSHOT).read_bytes())
    doc["sections"]["name"] = "edited"
    (tmp_path / SNAPSHOT).write_text(json.dumps(doc))
    again = await_open(tmp_path)
    assert again.get("name") == "edited"
    assert any("edited by hand" in text for text in again.restored.skipped)
    assert any(n.startswith("snapshot.json.edited") for n in aside(tmp_path))


async def test_a_damaged_blob_skips_only_its_section(tmp_path):
    store = await filled(tmp_path, [{"map": b"map bytes", "pois": ["a"]}])
    await store.close()
    blob = next((tmp_path / "blobs").iterdir())
    blob.write_bytes(b"garbage")
    again = await_open(tmp_path)
    assert again.get("map") is None and again.get("pois") == ["a"]
    assert any("'map' skipped" in text and "damaged" in text
               for text in again.restored.skipped)
    assert any(n.startswith("blobs.") for n in aside(tmp_path))


async def test_fresh_sets_everything_aside_and_reads_nothing(tmp_path):
    store = await filled(tmp_path, [{"a": 1}])
    await store.close()
    again = await_open(tmp_path, fresh=True)
    assert again.get("a") is None and again.restored.fresh
    assert {n.split(".fresh")[0] for n in aside(tmp_path)} == {SNAPSHOT, JOURNAL}


async def test_a_rejected_section_is_kept_aside(tmp_path):
    store = await filled(tmp_path, [{"pois": [{"name": ""}]}])
    await store.close()
    again = await_open(tmp_path)
    again.reject("pois", "field 'poi.name' must not be empty")
    assert any(n.startswith("pois.rejected") for n in aside(tmp_path))
    assert again.status()["errors"]


def test_identities_get_their_own_folders(tmp_path):
    names = {identity_folder(tmp_path, i) for i in ("sim-office", "a/b", "a_b", "..", "")}
    assert len(names) == 5 and all(p.parent == tmp_path for p in names)
    assert identity_folder(tmp_path, "sim-office").name == "sim-office"


def test_snapshot_round_trip():
    assert decode_snapshot(encode_snapshot(3, {"a": [1]})) == (3, {"a": [1]}, False)


async def test_a_value_that_cannot_be_written_fails_its_put_and_the_store_goes_on(tmp_path):
    store = StateStore.open(tmp_path)
    bad = store.put("pose", [float("nan")])
    await store.flush()
    assert isinstance(bad.exception(), OSError) and "write failed" in store.errors[-1]
    await store.put("pois", ["a"])  # the journal has no gap or half line
    await store.close()
    again = StateStore.open(tmp_path)
    assert again.get("pois") == ["a"] and again.restored.skipped == []

"""Map folder names and atomic folder writes (pure, on a temporary directory)."""

from __future__ import annotations

import os

import pytest

from hitrobot_server.nodes.ground.mapstore import (
    MAX_NAME_LENGTH,
    MapStore,
    StoreError,
    validate_name,
    write_file,
)


@pytest.mark.parametrize("name", ["localization", "navigation", "floor-2_v1.0", "Küche",
                                  "a b", "x" * MAX_NAME_LENGTH])
def test_good_names(name):
    assert validate_name(name) == name


@pytest.mark.parametrize("name, needle", [
    ("", "empty"),
    ("   ", "empty"),
    ("../x", "separators"),
    ("..", "'.'"),
    (".", "'.'"),
    (".hidden", "'.'"),
    ("/etc/passwd", "absolute"),
    ("\\\\server\\share", "absolute"),
    ("C:\\maps", "absolute"),
    ("a/b", "separators"),
    ("a\\b", "separators"),
    ("x" * (MAX_NAME_LENGTH + 1), "too long"),
    ("bad\x00name", "control"),
    ("tab\tname", "control"),
    (" lead", "letters"),
    ("trail ", "letters"),
    ("semi;colon", "letters"),
])
def test_bad_names(name, needle):
    with pytest.raises(StoreError, match=needle):
        validate_name(name)


def test_save_read_replace(tmp_path):
    store = MapStore(tmp_path / "maps")
    assert store.names() == []
    path = store.save("office", {"a.txt": b"one", "b.bin": b"\x00\x01"})
    assert path == (tmp_path / "maps" / "office").resolve()
    assert store.read("office", "a.txt") == b"one"
    assert store.has_file("office", "b.bin") and not store.has_file("office", "c")
    store.save("office", {"a.txt": b"two"})  # replaces the whole folder
    assert store.read("office", "a.txt") == b"two"
    assert not store.has_file("office", "b.bin")
    assert store.names() == ["office"]
    assert sorted(os.listdir(tmp_path / "maps")) == ["office"]  # no temporary leftovers
    with pytest.raises(StoreError, match="no saved map"):
        store.read("other", "a.txt")
    with pytest.raises(StoreError, match="no file"):
        store.read("office", "missing.yaml")


def test_names_never_leave_the_store(tmp_path):
    store = MapStore(tmp_path / "maps")
    for name in ("../escape", "/tmp/escape", "", "x" * 300):
        with pytest.raises(StoreError):
            store.save(name, {"a": b"x"})
    assert sorted(os.listdir(tmp_path)) == []  # not even the store was created
    (tmp_path / "maps").mkdir()
    (tmp_path / "outside").mkdir()
    (tmp_path / "maps" / "link").symlink_to(tmp_path / "outside")
    with pytest.raises(StoreError, match="leaves the map store"):
        store.save("link", {"a": b"x"})
    assert os.listdir(tmp_path / "outside") == []


def test_failed_save_leaves_the_old_folder(tmp_path, monkeypatch):
    store = MapStore(tmp_path)
    store.save("m", {"a": b"old"})
    calls = []

    def broken(path, data):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        write_file(path, data)

    monkeypatch.setattr("hitrobot_server.nodes.ground.mapstore.write_file", broken)
    with pytest.raises(StoreError, match="No space left"):
        store.save("m", {"a": b"new", "b": b"new"})
    assert store.read("m", "a") == b"old"
    assert sorted(os.listdir(tmp_path)) == ["m"]


def test_write_file_is_atomic(tmp_path):
    target = tmp_path / "f"
    write_file(target, b"1")
    write_file(target, b"2")
    assert target.read_bytes() == b"2"
    assert os.listdir(tmp_path) == ["f"]


def test_clean_leftovers_removes_interrupted_saves_and_restores_a_lone_old_copy(tmp_path):
    store = MapStore(tmp_path)
    store.save("kept", {"map.yaml": b"k"})
    store.save("lost", {"map.yaml": b"only copy"})
    (tmp_path / ".tmp-kept.1a2b").mkdir()
    (tmp_path / ".tmp-kept.1a2b" / "map.pgm").write_bytes(b"half")
    (tmp_path / ".old-kept.3c4d").mkdir()
    os.replace(tmp_path / "lost", tmp_path / ".old-lost.5e6f")  # crash between the renames
    (tmp_path / "kept" / ".tmp-map.yaml.0000").write_bytes(b"partial")
    removed = store.clean_leftovers()
    assert sorted(removed) == [".old-kept.3c4d", ".tmp-kept.1a2b", "kept/.tmp-map.yaml.0000"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept", "lost"]
    assert store.read("lost", "map.yaml") == b"only copy"
    assert os.listdir(tmp_path / "kept") == ["map.yaml"]


def test_a_file_linked_to_outside_the_store_is_refused(tmp_path):
    outside = tmp_path / "secret.pgm"
    outside.write_bytes(b"P5 not yours")
    store = MapStore(tmp_path / "maps")
    store.save("m", {"map.yaml": b"y"})
    (tmp_path / "maps" / "m" / "map.pgm").symlink_to(outside)
    with pytest.raises(StoreError, match="link to outside the map store"):
        store.read("m", "map.pgm")
    # a link that stays inside the store is fine
    (tmp_path / "maps" / "m" / "alias.yaml").symlink_to(tmp_path / "maps" / "m" / "map.yaml")
    assert store.read("m", "alias.yaml") == b"y"

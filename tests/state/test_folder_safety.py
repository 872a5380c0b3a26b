"""The state folder against files planted in it (issue 37, item 3): links are never followed
out of it, nothing outside is written or removed, modes stay private, reads are bounded before
they start, one server holds a folder, and a read-only one is refused with the reason.

The memory bounds are measured on a subprocess that opens the folder (its peak RSS, VmHWM),
against the same subprocess on a clean folder. The huge files are sparse: they cost no disk."""

from __future__ import annotations

import hashlib
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from hitrobot_server.state import StateFolderError, StateStore
from hitrobot_server.state.journal import encode_record, encode_snapshot
from tests.helpers import ServerProcess
from tests.state.failing_folder import FailingFolder

MiB = 1024 * 1024
BOUND = 100 * MiB  # what opening a damaged folder may cost over opening a clean one


def tree(root: Path) -> dict[str, tuple[int, bytes | str]]:
    """Every entry under ``root`` with its mode and content (a link's target), to show that
    nothing there changed."""
    found = {}
    for path in sorted(root.rglob("*")):
        st = path.lstat()
        body = os.readlink(path) if path.is_symlink() else (
            path.read_bytes() if path.is_file() else b"")
        found[str(path.relative_to(root))] = (st.st_mode, body)
    return found


def outside(tmp_path: Path) -> Path:
    victim = tmp_path / "outside"
    victim.mkdir()
    (victim / "victim1.txt").write_bytes(b"keep me")
    (victim / "important.db").write_bytes(b"\x00db")
    (victim / "secret").write_bytes(b"private\n")
    (victim / "secret").chmod(0o600)
    return victim


def private(folder: Path) -> None:
    """Files 0600 and folders 0700, the folder itself included (links excepted: moved
    aside as links)."""
    for path in [folder, *folder.rglob("*")]:
        mode = path.lstat().st_mode
        if stat.S_ISLNK(mode):
            continue
        want = 0o700 if stat.S_ISDIR(mode) else 0o600
        assert stat.S_IMODE(mode) == want, (path, oct(mode))


async def test_a_linked_blobs_folder_is_set_aside_and_nothing_outside_is_removed(tmp_path):
    victim = outside(tmp_path)
    before = tree(victim)
    folder = tmp_path / "state"
    store = StateStore.open(folder)
    await store.put("map", b"map bytes")
    await store.close()
    (folder / "blobs").rename(tmp_path / "old-blobs")
    (folder / "blobs").symlink_to(victim)
    again = StateStore.open(folder)
    assert again.get("map") is None  # its blob is not where it belongs: skipped, not followed
    assert any("blobs: a symbolic link" in text for text in again.restored.skipped)
    assert (folder / "blobs").is_dir() and not (folder / "blobs").is_symlink()
    assert [p.name for p in (folder / "set-aside").iterdir() if p.is_symlink()] != []
    await again.close()
    assert tree(victim) == before
    private(folder)


async def test_a_linked_set_aside_folder_gets_nothing_written_through_it(tmp_path):
    victim = outside(tmp_path)
    before = tree(victim)
    folder = tmp_path / "state"
    await StateStore.open(folder).close()
    (folder / "journal.log").write_bytes(encode_record(1, {"a": 1}) + b"damaged tail\n")
    (folder / "set-aside").symlink_to(victim)
    store = StateStore.open(folder)
    assert store.get("a") == 1
    assert any("journal.log: a damaged record" in text for text in store.restored.skipped)
    assert (folder / "set-aside").is_dir() and not (folder / "set-aside").is_symlink()
    assert any(p.name.startswith("journal.log.tail") for p in (folder / "set-aside").iterdir())
    await store.close()
    assert tree(victim) == before
    private(folder)


async def test_a_linked_journal_is_not_read_nor_copied(tmp_path):
    victim = outside(tmp_path)
    before = tree(victim)
    folder = tmp_path / "state"
    await StateStore.open(folder).close()
    (folder / "journal.log").unlink()
    (folder / "journal.log").symlink_to(victim / "secret")
    store = StateStore.open(folder)
    assert any("journal.log: a symbolic link" in text for text in store.restored.skipped)
    await store.put("b", 2)  # the new journal is the store's own file
    await store.close()
    assert tree(victim) == before
    contents = [p.read_bytes() for p in folder.rglob("*") if p.is_file() and not p.is_symlink()]
    assert all(b"private" not in c for c in contents)  # never copied in
    private(folder)


def peak_rss_opening(folder: Path) -> tuple[int, str]:
    """Peak RSS (bytes) of a fresh process that opens ``folder``, and what it restored."""
    code = (
        "import sys\n"
        "from hitrobot_server.state import StateStore\n"
        "s = StateStore.open(sys.argv[1])\n"
        "print(sorted(s.keys()), s.restored.skipped)\n"
        "print(next(l for l in open('/proc/self/status') if l.startswith('VmHWM')).split()[1])\n")
    out = subprocess.run([sys.executable, "-c", code, str(folder)], capture_output=True,
                         text=True, timeout=60, check=True, env={**os.environ})
    restored, hwm = out.stdout.strip().rsplit("\n", 1)
    return int(hwm) * 1024, restored


def sparse(path: Path, size: int, head: bytes = b"") -> None:
    with open(path, "wb") as f:
        f.write(head)
        f.truncate(size)


async def test_a_500_mib_journal_line_and_a_512_mib_blob_are_refused_before_reading(tmp_path):
    clean = tmp_path / "clean"
    await StateStore.open(clean).close()
    control, _ = peak_rss_opening(clean)

    line = tmp_path / "line"
    line.mkdir()
    (line / "journal.log").write_bytes(encode_record(1, {"a": 1}))
    with open(line / "journal.log", "ab") as f:
        f.truncate(f.tell() + 500 * MiB)  # one line of 500 MiB (no newline)
    hwm, restored = peak_rss_opening(line)
    assert "['a']" in restored and "longer than" in restored, restored
    assert hwm - control < BOUND, (hwm, control)
    assert sum(p.stat().st_blocks for p in line.rglob("*") if p.is_file()) * 512 < 4 * MiB

    blob = tmp_path / "blob"
    (blob / "blobs").mkdir(parents=True)
    digest = hashlib.sha256(b"whatever").hexdigest()
    (blob / "snapshot.json").write_bytes(encode_snapshot(
        1, {"map": {"$blob": digest, "size": 512 * MiB}, "b": 2}))
    sparse(blob / "blobs" / digest, 512 * MiB)
    hwm, restored = peak_rss_opening(blob)
    assert "['b']" in restored and "too large" in restored, restored
    assert hwm - control < BOUND, (hwm, control)
    assert any(p.name.startswith(f"blobs.{digest}.too-large")
               for p in (blob / "set-aside").iterdir())  # set aside, not deleted


async def test_one_store_holds_a_folder_and_names_the_holder(tmp_path):
    first = StateStore.open(tmp_path)
    with pytest.raises(StateFolderError, match=f"in use by another server \\(pid {os.getpid()}\\)"):
        StateStore.open(tmp_path)
    await first.close()
    await StateStore.open(tmp_path).close()  # free once the holder let go


def test_a_second_server_on_the_folder_refuses_to_start(tmp_path):
    state = tmp_path / "state"
    first = ServerProcess("--state-dir", str(state), robot="sim")
    try:
        second = subprocess.run(
            [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "-1",
             "--address", "127.0.0.1", "--robot", "sim", "--state-dir", str(state)],
            capture_output=True, text=True, timeout=60)
        assert second.returncode == 1
        assert f"is in use by another server (pid {first.proc.pid})" in second.stderr
    finally:
        first.stop()


def test_a_read_only_folder_is_refused_with_the_reason(tmp_path):
    ro = FailingFolder(tmp_path / "state")
    try:
        (ro.root / "sim-office").mkdir()
        ro.fail(ro.root / "sim-office")
        if ro.mounted:  # a full tmpfs: remount it read-only, as a read-only disk is
            subprocess.run(["mount", "-o", "remount,ro", str(ro.root)], check=True, timeout=10)
        with pytest.raises(StateFolderError) as refused:
            StateStore.open(ro.root / "sim-office")
        text = str(refused.value)
        assert "cannot be used" in text and "--state-dir" in text
        assert ("read-only file system" if ro.mounted else "permission denied") in text
    finally:
        if ro.mounted:
            subprocess.run(["mount", "-o", "remount,rw", str(ro.root)], timeout=10)
        ro.close()


async def test_snapshot_content_is_never_read_through_a_link(tmp_path):
    victim = outside(tmp_path)
    folder = tmp_path / "state"
    folder.mkdir()
    (victim / "snap").write_bytes(encode_snapshot(1, {"stolen": "x"}))
    (folder / "snapshot.json").symlink_to(victim / "snap")
    store = StateStore.open(folder)
    assert store.get("stolen") is None
    await store.close()
    assert (victim / "snap").read_bytes() == encode_snapshot(1, {"stolen": "x"})

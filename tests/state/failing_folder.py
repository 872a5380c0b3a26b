"""A state root whose writes can be made to fail for real, for the durable-ack tests: a small
tmpfs filled to the last page when this user may mount one (root), else the state folder made
read-only by its modes (a non-root server cannot write it). :attr:`reason` is what the server
must say."""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import subprocess
from pathlib import Path

SIZE = "8m"


class FailingFolder:
    def __init__(self, root: Path) -> None:
        self.root = root
        root.mkdir(parents=True, exist_ok=True)
        self.mounted = os.geteuid() == 0 and subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={SIZE},mode=0700", "tmpfs", str(root)],
            capture_output=True, timeout=10).returncode == 0
        self.reason = "disk full" if self.mounted else "permission denied"
        self._filler = root / "filler"
        self._locked: list[tuple[Path, int]] = []

    def fail(self, folder: Path) -> None:
        """From now on writes into ``folder`` fail."""
        if self.mounted:
            chunk = b"\0" * 4096
            with open(self._filler, "wb", buffering=0) as f:
                for _ in range(10_000):  # 8 MiB is 2,048 chunks: bounded
                    try:
                        f.write(chunk)
                    except OSError as exc:
                        assert exc.errno == errno.ENOSPC
                        break
            return
        for path in [*folder.rglob("*"), folder]:
            if path.is_symlink():
                continue
            mode = path.stat().st_mode
            self._locked.append((path, mode))
            path.chmod(stat.S_IMODE(mode) & ~0o222)

    def free(self) -> None:
        """Writes work again."""
        with contextlib.suppress(FileNotFoundError):
            self._filler.unlink()
        for path, mode in reversed(self._locked):
            path.chmod(stat.S_IMODE(mode))
        self._locked.clear()

    def close(self) -> None:
        self.free()
        if self.mounted:
            subprocess.run(["umount", "-l", str(self.root)], capture_output=True, timeout=10)

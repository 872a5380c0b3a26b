"""Memory of the server as a whole: its own process and its child processes (the worker pool
that parses and encodes big messages), read from Linux's /proc without psutil.

A worker's memory is not in the server's own RSS, yet a hostile message can make it the
biggest part (a typed-array bomb once grew a worker by 1 GB): diagnostics and the benches add
them up. Off Linux the figures are 0.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


def rss_bytes(pid: int) -> int:
    """Resident set size of ``pid`` right now (0 when it is gone or /proc is missing)."""
    try:
        return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * _PAGE
    except (OSError, IndexError, ValueError):
        return 0


def peak_bytes(pid: int) -> int:
    """Peak resident set size of ``pid`` (``VmHWM``), 0 when unknown."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    except (OSError, IndexError, ValueError):
        pass
    return 0


def children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid``: from the kernel's per-thread ``children`` lists
    (a few small reads), else by scanning every process's ``stat``."""
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
        lists = [Path(f"/proc/{pid}/task/{tid}/children").read_text() for tid in tasks]
    except OSError:  # gone, or a kernel without CONFIG_PROC_CHILDREN
        return _scan_children(pid)
    return sorted({int(child) for text in lists for child in text.split()})


def _scan_children(pid: int) -> list[int]:
    found: list[int] = []
    try:
        entries = os.listdir("/proc")
    except OSError:
        return found
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat.rpartition(")")[2].split()  # the name in () may hold spaces
        if len(fields) > 1 and fields[1] == str(pid):
            found.append(int(entry))
    return found


@dataclass(frozen=True)
class Memory:
    """Resident bytes of the server process and of its child processes."""

    main: int
    workers: int
    worker_count: int

    @property
    def total(self) -> int:
        return self.main + self.workers


def memory(pid: int | None = None) -> Memory:
    """The resident memory of ``pid`` (this process by default) and of its children."""
    pid = os.getpid() if pid is None else pid
    kids = children(pid)
    return Memory(rss_bytes(pid), sum(rss_bytes(k) for k in kids), len(kids))

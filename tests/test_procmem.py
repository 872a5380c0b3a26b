"""The server's memory figures count its child processes (the worker pool) too."""

from __future__ import annotations

import os
import subprocess
import sys

from hitrobot_server import procmem


def test_memory_adds_up_the_children_of_a_process():
    hold = "b = bytearray(64 * 1024 * 1024); b[::4096] = b'x' * len(b[::4096]); " \
           "import sys; sys.stdout.write('ready\\n'); sys.stdout.flush(); sys.stdin.read()"
    child = subprocess.Popen([sys.executable, "-c", hold], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline() == "ready\n"
        assert child.pid in procmem.children(os.getpid())
        mem = procmem.memory()
        assert mem.worker_count >= 1
        assert mem.workers >= 64 * 1024 * 1024  # the child's touched 64 MiB are counted
        assert mem.main > 0
        assert mem.total == mem.main + mem.workers
        assert procmem.peak_bytes(child.pid) >= 64 * 1024 * 1024
    finally:
        child.stdin.close()
        child.wait(10)
    assert child.pid not in procmem.children(os.getpid())
    assert procmem.rss_bytes(child.pid) == 0

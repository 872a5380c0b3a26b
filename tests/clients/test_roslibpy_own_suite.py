"""roslibpy's own test suite, whole, against the server with ``--demo-services`` (issue 49).

The suite is the sdist of the roslibpy installed here (fetched by pip at test time: it ships
tests/, the wheel does not), run unchanged by ``roslibpy_suite_runner.py`` once per transport
(twisted and asyncio, as their CI does), each in a network namespace of its own where its
hard-coded port 9090 is free; both run at once.
"""

from __future__ import annotations

import importlib.metadata
import os
import re
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

RUNNER = Path(__file__).with_name("roslibpy_suite_runner.py")
TRANSPORTS = ("twisted", "asyncio")
TIMEOUT = 200


# a network namespace: as root, or in a user namespace of its own where user namespaces are on
UNSHARE = ["unshare", "-n"] if os.geteuid() == 0 else ["unshare", "-r", "-n"]


def _namespaces() -> bool:
    """Whether this machine lets us make a network namespace."""
    if not (shutil.which("unshare") and shutil.which("ip")):
        return False
    return subprocess.run([*UNSHARE, "true"], capture_output=True).returncode == 0


def _suite(into: Path) -> Path:
    """The installed roslibpy's sdist, unpacked: its tests/ and pytest settings."""
    version = importlib.metadata.version("roslibpy")
    subprocess.run(
        [sys.executable, "-m", "pip", "download", f"roslibpy=={version}", "--no-binary",
         ":all:", "--no-deps", "-q", "-d", str(into)],
        check=True, capture_output=True, timeout=120,
    )
    (sdist,) = into.glob("roslibpy-*.tar.gz")
    with tarfile.open(sdist) as tar:
        tar.extractall(into, filter="data")
    root = into / f"roslibpy-{version}"
    assert (root / "tests" / "ros1").is_dir() and (root / "tests" / "ros2").is_dir()
    return root


@pytest.mark.timeout(TIMEOUT + 60)
def test_roslibpy_own_suite_passes_whole(tmp_path):
    if not _namespaces():
        pytest.fail("needs `unshare -n` and `ip` (util-linux, iproute2) and the right to "
                    "make a network namespace: roslibpy's tests dial the fixed port 9090")
    suite = _suite(tmp_path / "sdist")
    runs = {}
    for transport in TRANSPORTS:
        state = tmp_path / f"state-{transport}"
        state.mkdir()
        runs[transport] = subprocess.Popen(
            [*UNSHARE, sys.executable, str(RUNNER), str(suite), transport, str(state)],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        )
    outputs = {t: p.communicate(timeout=TIMEOUT)[0] for t, p in runs.items()}
    for transport, output in outputs.items():
        assert runs[transport].returncode == 0, f"{transport}:\n{output[-6000:]}"
        summary = re.findall(r"^.*\b\d+ passed.*$", output, re.M)[-1]  # pytest's last line
        assert not re.search(r"\b(failed|error)", summary), f"{transport}: {summary}"
        passed = int(re.search(r"(\d+) passed", summary).group(1))
        assert passed >= 50, f"{transport}: {summary}"  # all of ros1/, ros2/ and the rest

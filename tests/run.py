"""The test command (what CI runs): ``python -m tests.run [pytest arguments]``.

Two passes of pytest over the same selection. The first spreads the tests over one worker
per CPU (pytest-xdist; most tests wait on sockets, servers and browsers, so the 2-core CI
machine runs two at once). The second runs, one at a time, the tests marked ``serial``: those
that measure the server's round trips or CPU share against a bound, which another test's load
would distort. Every test runs exactly once; the exit status is the worse of the two.
"""

from __future__ import annotations

import subprocess
import sys

NO_TESTS = 5  # pytest's exit status when a pass selects nothing (e.g. no serial test asked)


def passes(args: list[str]) -> list[list[str]]:
    pytest = [sys.executable, "-m", "pytest"]
    return [[*pytest, "-n", "auto", "--dist", "loadfile", "-m", "not serial", *args],
            [*pytest, "-p", "no:xdist", "-m", "serial", *args]]


def main(args: list[str]) -> int:
    statuses = [subprocess.call(command) for command in passes(args)]
    ran = [status for status in statuses if status != NO_TESTS]
    return max(ran) if ran else NO_TESTS


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

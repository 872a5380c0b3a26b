"""A SIGTERM sent the moment the banner is read stops the server cleanly: the handlers are in
place before the banner is printed (signals.catch_termination, as a command's loop starts).
Scripts, systemd and the manual's snippet test all stop a server right after that line; half
of those stops used to be the default kill (exit -15) before."""

from __future__ import annotations

import signal

from tests.helpers import ServerProcess


def test_a_sigterm_right_after_the_banner_is_a_clean_stop():
    for _ in range(3):
        server = ServerProcess()  # returns as soon as the banner line is read
        server.proc.send_signal(signal.SIGTERM)
        assert server.proc.wait(10) == 0, "".join(server.output)
        server.stop()


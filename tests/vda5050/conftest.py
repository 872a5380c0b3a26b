"""A real MQTT broker for the VDA 5050 tests: Debian's mosquitto on a free loopback port, with
a temporary configuration (anonymous clients, no persistence), stopped after the test."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
from pathlib import Path

import pytest

MOSQUITTO = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
START_TIMEOUT = 10.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Broker:
    def __init__(self, folder: Path, extra: str = "", anonymous: bool = True):
        if not Path(MOSQUITTO).exists():
            raise RuntimeError("mosquitto is not installed: `apt-get install mosquitto` "
                               "(.ci/run does this)")
        self.port = free_port()
        self.config = folder / "mosquitto.conf"
        self.config.write_text(f"listener {self.port} 127.0.0.1\n"
                               f"allow_anonymous {'true' if anonymous else 'false'}\n"
                               "persistence false\nmax_packet_size 4194304\n"
                               # as root it would turn into the user mosquitto, who may not
                               # read the test's files (certificates, passwords)
                               + ("user root\n" if os.geteuid() == 0 else "") + extra)
        self._start()

    def restart(self) -> Broker:
        """The same broker again, on the same port (after :meth:`stop`)."""
        self._start()
        return self

    def _start(self) -> None:
        self.proc = subprocess.Popen([MOSQUITTO, "-c", str(self.config)],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + START_TIMEOUT
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), 0.5).close()
                break
            except OSError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    if self.proc.poll() is None:
                        self.proc.kill()
                    why = self.proc.communicate(timeout=5)[1].decode()
                    raise RuntimeError(f"mosquitto did not start: {why}") from None
                time.sleep(0.05)

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        if self.proc.stderr is not None:
            self.proc.stderr.close()


@pytest.fixture
def broker(tmp_path):
    b = Broker(tmp_path)
    yield b
    b.stop()

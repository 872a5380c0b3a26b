"""What the VDA 5050 interface needs of the server's settings; each field's ``help`` makes its
flag and TOML key. Off unless ``--vda5050`` names a broker."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from urllib.parse import unquote, urlsplit

NAME = re.compile(r"[A-Za-z0-9_.:-]{1,128}")
"""What the spec allows in a topic's manufacturer and serial number levels."""
INTERFACE = re.compile(r"[^/#+\x00]{1,64}")
PORTS = {"mqtt": 1883, "mqtts": 8883}


@dataclass(frozen=True)
class Broker:
    """Where the vehicles connect: host, port, TLS, and the credentials in the URL."""

    host: str
    port: int
    tls: bool
    username: str | None = None
    password: str | None = None

    @property
    def url(self) -> str:
        """The broker as shown to a user (no password)."""
        return f"{'mqtts' if self.tls else 'mqtt'}://{self.host}:{self.port}"


def parse_broker(url: str) -> Broker:
    """``mqtt://HOST:PORT`` or ``mqtts://[USER:PASSWORD@]HOST:PORT`` (ValueError otherwise)."""
    parts = urlsplit(url)
    if parts.scheme not in PORTS or not parts.hostname:
        raise ValueError(f"--vda5050 {url!r}: give mqtt://HOST:PORT or mqtts://HOST:PORT")
    try:
        port = parts.port or PORTS[parts.scheme]
    except ValueError:
        raise ValueError(f"--vda5050 {url!r}: the port is not a number") from None
    return Broker(parts.hostname, port, parts.scheme == "mqtts",
                  unquote(parts.username) if parts.username else None,
                  unquote(parts.password) if parts.password else None)


@dataclass(frozen=True)
class Vda5050Options:
    vda5050: str | None = field(default=None, metadata={
        "help": "speak VDA 5050 2.0.0 to a master control through this MQTT broker "
        "(mqtt://HOST:PORT, or mqtts://[USER:PASSWORD@]HOST:PORT): every robot a vehicle; "
        "needs the [vda5050] extra (default: off)"})
    vda5050_manufacturer: str = field(default="hitrobot", metadata={
        "help": "VDA 5050: the manufacturer level of every vehicle's topics"})
    vda5050_serial: str = field(default="", metadata={
        "help": "VDA 5050: the single robot's serial number; named robots use their names "
        "(default: robot)"})
    vda5050_interface: str = field(default="uagv", metadata={
        "help": "VDA 5050: the interface name, the first level of every topic"})
    vda5050_password_file: str | None = field(default=None, metadata={
        "help": "VDA 5050: read the broker password from this file (the user name is in the "
        "URL), so it is not on the command line"})
    vda5050_ca_file: str | None = field(default=None, metadata={
        "help": "VDA 5050: mqtts: the CA certificates that sign the broker's (default: the "
        "system's)"})
    vda5050_cert_file: str | None = field(default=None, metadata={
        "help": "VDA 5050: mqtts: the client certificate (PEM) to present to the broker"})
    vda5050_key_file: str | None = field(default=None, metadata={
        "help": "VDA 5050: mqtts: the client certificate's private key (PEM)"})

    @property
    def broker(self) -> Broker | None:
        return parse_broker(self.vda5050) if self.vda5050 else None

    def check(self) -> None:
        broker = self.broker
        if broker is None:
            return
        if not NAME.fullmatch(self.vda5050_manufacturer):
            raise ValueError("--vda5050-manufacturer: 1-128 of A-Z a-z 0-9 _ . : -")
        if self.vda5050_serial and not NAME.fullmatch(self.vda5050_serial):
            raise ValueError("--vda5050-serial: 1-128 of A-Z a-z 0-9 _ . : -")
        if not INTERFACE.fullmatch(self.vda5050_interface):
            raise ValueError("--vda5050-interface: 1-64 characters, none of / # +")
        if (self.vda5050_cert_file or self.vda5050_key_file or self.vda5050_ca_file) \
                and not broker.tls:
            raise ValueError("--vda5050-cert-file, --vda5050-key-file and --vda5050-ca-file "
                             "need an mqtts:// broker")
        if bool(self.vda5050_cert_file) != bool(self.vda5050_key_file):
            raise ValueError("--vda5050-cert-file and --vda5050-key-file go together")

    def password(self) -> str | None:
        """The broker password: the file's first line, else the URL's."""
        if self.vda5050_password_file:
            with open(self.vda5050_password_file, encoding="utf-8") as f:
                return f.readline().rstrip("\r\n")
        broker = self.broker
        return broker.password if broker else None

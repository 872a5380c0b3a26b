"""What the transports need to know of the server's settings: where to listen and how.

Each field's ``help`` (metadata) makes its flag and TOML key, its default is the server's;
``config.py`` only composes the layers' options.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class TransportOptions:
    """The WebSocket and TCP listeners, their pacing, pings and TLS."""

    port: int = field(default=9090, metadata={
        "help": "WebSocket port (0 = pick a free one); plain HTTP GET on it serves the web UI"})
    address: str = field(default="127.0.0.1", metadata={
        "help": "address to bind; 127.0.0.1 by default, use 0.0.0.0 to serve a robot LAN"})
    tcp_port: int = field(default=9091, metadata={
        "help": "raw TCP JSON port (one JSON object per line out); 0 = off, -1 = pick a free "
        "one"})
    delay_between_messages: float = field(default=0.0, metadata={
        "help": "seconds to wait after each frame sent to a client"})
    use_compression: bool = field(default=False, metadata={
        "help": "offer WebSocket permessage-deflate"})
    websocket_ping_interval: float = field(default=0.0, metadata={
        "help": "seconds between WebSocket pings to each client (0 = none)"})
    websocket_ping_timeout: float = field(default=30.0, metadata={
        "help": "seconds a client has to answer a ping before it is disconnected"})
    send_window: bool = field(default=True, metadata={
        "help": "hold a WebSocket client that shows a standing queue (its pongs over 0.5 s late "
        "for 0.3 s) to about 30 ms of its delivery rate unread, learnt from pings, so a small "
        "topic stays fresh behind a big stream on deep socket buffers; a client that reads "
        "what it is sent is never held, one that answers no ping never (--no-send-window: "
        "never hold)"})
    ssl: bool = field(default=False, metadata={
        "help": "serve wss:// and TLS on the TCP port (needs --certfile)"})
    certfile: str | None = field(default=None, metadata={
        "help": "PEM certificate chain for --ssl (may also hold the key)"})
    keyfile: str | None = field(default=None, metadata={
        "help": "PEM private key for --ssl (if not in --certfile)"})
    tls_handshake_timeout: float = field(default=5.0, metadata={
        "help": "seconds a client has to finish the TLS handshake (--ssl), on both ports"})
    max_tls_handshakes: int = field(default=64, metadata={
        "help": "TLS handshakes in progress at once, all clients together; a connection "
        "beyond it is closed at once"})
    max_tls_handshakes_per_address: int = field(default=8, metadata={
        "help": "TLS handshakes in progress at once from one source address"})

    def check(self) -> None:
        """Refuse values the listeners cannot work with (``ValueError`` naming the setting)."""
        if self.ssl and not self.certfile:
            raise ValueError("--ssl needs --certfile (and --keyfile unless the key is in it)")
        if self.websocket_ping_interval < 0 or self.websocket_ping_timeout <= 0:
            raise ValueError("websocket_ping_interval must be 0 or more and "
                             "websocket_ping_timeout positive")
        if self.tls_handshake_timeout <= 0:
            raise ValueError("tls_handshake_timeout must be positive")
        if self.max_tls_handshakes < 1 or self.max_tls_handshakes_per_address < 1:
            raise ValueError("max_tls_handshakes and max_tls_handshakes_per_address must be "
                             "positive")

    def schemes(self) -> tuple[str, str]:
        """The URL schemes the banner prints: ``ws``/``tcp``, or with TLS ``wss``/``tcp+tls``."""
        return ("wss", "tcp+tls") if self.ssl else ("ws", "tcp")

"""What a session needs to know of the server's settings; the command line builds it."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..bus.names import GlobFilter, access_filters


@dataclass
class SessionOptions:
    """Per-client limits and access rules (defaults are the server's defaults)."""

    authenticate: bool = False
    auth_secret: str | None = field(default=None, repr=False)
    client_tag: str = ""  # keeps client node names unique across servers sharing a bus
    fragment_timeout: float = 600.0
    fragment_memory_limit: int = 512 * 1024 * 1024
    max_frame_size: int = 256 * 1024 * 1024
    max_message_size: int | None = None
    send_buffer_limit: int = 10_000_000
    reply_buffer_limit: int = 16_000_000
    status_level: str = "error"
    call_service_timeout: float | None = None
    topics_glob: str | None = None
    services_glob: str | None = None
    topics_filter: GlobFilter = field(init=False, repr=False)
    services_filter: GlobFilter = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.topics_filter, self.services_filter, _ = access_filters(
            self.topics_glob, self.services_glob
        )

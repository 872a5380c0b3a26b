"""What a session needs to know of the server's settings; the command line builds it."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..bus.names import GlobFilter, access_filters
from ..protocol.fragment import MIN_FRAGMENT_SIZE


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
    max_requests_in_flight: int = 1000  # per client: call_service and action goals each
    topics_glob: str | None = None
    services_glob: str | None = None
    params_glob: str | None = None  # Foxglove's parameter ops (rosbridge's go through rosapi)
    topics_filter: GlobFilter = field(init=False, repr=False)
    services_filter: GlobFilter = field(init=False, repr=False)
    params_filter: GlobFilter = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.max_message_size is not None:  # never cut replies finer than the floor
            self.max_message_size = max(self.max_message_size, MIN_FRAGMENT_SIZE)
        self.topics_filter, self.services_filter, self.params_filter = access_filters(
            self.topics_glob, self.services_glob, self.params_glob
        )

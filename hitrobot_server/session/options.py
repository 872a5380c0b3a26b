"""What a session needs to know of the server's settings.

The fields a user sets (their ``help`` in the metadata makes the flag and the TOML key, their
default is the server's) and their checks live here; ``config.py`` only composes them. The
sessions get :meth:`SessionOptions.for_sessions`: a copy with what the server learns at start
(the secret, the client tag) and the fragment size raised to the floor.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ..bus.names import GlobFilter, access_filters
from ..protocol.fragment import MIN_FRAGMENT_SIZE

STATUS_LEVELS = ("info", "warning", "error", "none")


@dataclass(frozen=True)
class SessionOptions:
    """Per-client limits and access rules."""

    authenticate: bool = field(default=False, metadata={
        "help": "require a token (hitrobot-server token add) or a rosauth MAC from every "
        "client, on every port, and check each op against the client's role"})
    auth_secret_file: str | None = field(default=None, metadata={
        "help": "file whose first line is the 16-character rosauth secret (rosauth MACs are "
        "accepted only with it)"})
    tokens_file: str | None = field(default=None, metadata={
        "help": "the named tokens (default: STATE_DIR/tokens.json, where 'hitrobot-server "
        "token' writes them)"})
    roles: str | None = field(default=None, metadata={
        "help": "JSON file of roles replacing or adding to the built-in viewer, operator, "
        "admin, agent and monitor"})
    fragment_timeout: float = field(default=600.0, metadata={
        "help": "seconds an incomplete fragmented message is kept"})
    max_message_size: int | None = field(default=None, metadata={
        "help": "fragment outgoing JSON ops longer than this many characters"})
    max_frame_size: int = field(default=256 * 1024 * 1024, metadata={
        "help": "largest incoming WebSocket frame (and fragmented message) accepted, in bytes"})
    fragment_memory_limit: int = field(default=512 * 1024 * 1024, metadata={
        "help": "bytes of incoming fragments held for all clients together"})
    call_service_timeout: float | None = field(default=None, metadata={
        "help": "default timeout of call_service in seconds (none = wait forever)"})
    max_requests_in_flight: int = field(default=1000, metadata={
        "help": "service calls (and, separately, action goals) one client may have waiting "
        "for an answer; more are refused with a status"})
    topics_glob: str | None = field(default=None, metadata={
        "help": "comma-separated fnmatch patterns of topics clients may use"})
    services_glob: str | None = field(default=None, metadata={
        "help": "comma-separated fnmatch patterns of services clients may use"})
    # Foxglove's parameter ops (rosbridge's go through rosapi)
    params_glob: str | None = field(default=None, metadata={
        "help": "comma-separated fnmatch patterns of parameters clients may use"})
    status_level: str = field(default="error", metadata={
        "help": "initial status level of each client: info, warning, error or none",
        "choices": STATUS_LEVELS})
    send_buffer_limit: int = field(default=10_000_000, metadata={
        "help": "bytes queued per client before its oldest topic messages are dropped"})
    reply_buffer_limit: int = field(default=16_000_000, metadata={
        "help": "bytes of replies and statuses queued per client before its input is no "
        "longer read and its requests are refused; at twice this it is disconnected"})
    # Known at start, not set by the user: the secret read from auth_secret_file, and the tag
    # that keeps client node names unique across servers sharing a bus.
    auth_secret: str | None = field(default=None, repr=False)
    client_tag: str = ""
    topics_filter: GlobFilter = field(init=False, repr=False)
    services_filter: GlobFilter = field(init=False, repr=False)
    params_filter: GlobFilter = field(init=False, repr=False)

    def __post_init__(self) -> None:
        filters = access_filters(self.topics_glob, self.services_glob, self.params_glob)
        for name, value in zip(("topics_filter", "services_filter", "params_filter"), filters,
                               strict=True):
            object.__setattr__(self, name, value)

    def for_sessions(self, auth_secret: str | None = None, client_tag: str = "") -> SessionOptions:
        """What each session gets: these options with the secret and the client tag the
        server learnt at start, the fragment size never finer than the floor."""
        size = self.max_message_size
        return replace(self, auth_secret=auth_secret, client_tag=client_tag,
                       max_message_size=None if size is None else max(size, MIN_FRAGMENT_SIZE))

    def check(self) -> None:
        """Refuse values the sessions cannot work with (``ValueError`` naming the setting)."""
        if self.status_level not in STATUS_LEVELS:
            raise ValueError(f"status_level must be one of {', '.join(STATUS_LEVELS)}")
        if self.max_requests_in_flight < 1:
            raise ValueError("max_requests_in_flight must be positive")
        if self.fragment_memory_limit < 1:
            raise ValueError("fragment_memory_limit must be positive")

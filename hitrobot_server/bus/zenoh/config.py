"""The Zenoh session's configuration, from the ``--zenoh-*`` options."""

from __future__ import annotations

from collections.abc import Iterable

import orjson
import zenoh


def session_config(
    config_file: str | None, connect: Iterable[str], listen: Iterable[str]
) -> zenoh.Config:
    """Peer mode, no multicast scouting, loopback unless told otherwise; a file replaces
    these defaults, explicit endpoints still apply on top of it."""
    try:
        config = zenoh.Config.from_file(config_file) if config_file else zenoh.Config()
    except zenoh.ZError as exc:
        raise ValueError(f"zenoh config {config_file}: {exc}") from None
    if not config_file:
        config.insert_json5("mode", '"peer"')
        config.insert_json5("scouting/multicast/enabled", "false")
        # Zenoh's own default listens on every interface; ours stays on loopback.
        listen = list(listen) or ["tcp/127.0.0.1:0"]
    try:
        for key, values in (("connect", list(connect)), ("listen", list(listen))):
            if values:
                config.insert_json5(f"{key}/endpoints", orjson.dumps(values).decode())
    except zenoh.ZError as exc:
        raise ValueError(f"zenoh endpoints: {exc}") from None
    return config

"""Server settings: one dataclass filled from defaults, a TOML file, then command-line flags.

Flag names follow rosbridge_websocket's parameters so a rosbridge user finds them. Config sits
at the top: each layer defines its own small options object (``SessionOptions``,
``NodeOptions``, ``RobotOptions``) and :class:`Settings` builds them to hand down.
"""

from __future__ import annotations

import argparse
import os
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from .nodes.options import NodeOptions, SlamwareParams
from .robot.options import RobotOptions
from .session.options import SessionOptions
from .state import default_root as default_state_root

STATUS_LEVELS = ("info", "warning", "error", "none")


@dataclass
class Settings:
    port: int = 9090
    address: str = "127.0.0.1"
    tcp_port: int = 9091
    authenticate: bool = False
    auth_secret_file: str | None = None
    fragment_timeout: float = 600.0
    max_message_size: int | None = None
    max_frame_size: int = 256 * 1024 * 1024
    fragment_memory_limit: int = 512 * 1024 * 1024
    delay_between_messages: float = 0.0
    unregister_timeout: float = 10.0
    call_service_timeout: float | None = None
    topics_glob: str | None = None
    services_glob: str | None = None
    params_glob: str | None = None
    status_level: str = "error"
    send_buffer_limit: int = 10_000_000
    use_compression: bool = False
    websocket_ping_interval: float = 0.0
    websocket_ping_timeout: float = 30.0
    ssl: bool = False
    certfile: str | None = None
    keyfile: str | None = None
    log_level: str = "info"
    robot: str = "sim"
    world: str | None = None
    sim_seed: int = 0
    sim_speed: float = 1.0
    sim_mapping: bool = False
    map_dir: str | None = None
    state_dir: str | None = None
    fresh: bool = False
    bus: str = "local"
    zenoh_config: str | None = None
    zenoh_connect: str | None = None
    zenoh_listen: str | None = None
    zenoh_domain: int = 0
    slamware: SlamwareParams = field(default_factory=SlamwareParams)
    auth_secret: str | None = field(default=None, repr=False)
    # Set by the server when it shares a bus: client node names stay unique across servers.
    client_tag: str = field(default="", repr=False)
    @property
    def map_store(self) -> Path:
        """Where map folders are saved: ``--map-dir`` or the per-user data directory."""
        if self.map_dir:
            return Path(self.map_dir)
        base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
        return Path(base) / "hitrobot-server" / "maps"

    @property
    def state_root(self) -> Path:
        """Where robots' state folders are (one per robot identity): ``--state-dir`` or
        ``$XDG_STATE_HOME/hitrobot-server``."""
        return Path(self.state_dir) if self.state_dir else default_state_root()

    def session_options(self) -> SessionOptions:
        """What each client session gets (built when a client connects, so the secret and
        client tag set at start are in)."""
        return SessionOptions(
            authenticate=self.authenticate,
            auth_secret=self.auth_secret,
            client_tag=self.client_tag,
            fragment_timeout=self.fragment_timeout,
            fragment_memory_limit=self.fragment_memory_limit,
            max_frame_size=self.max_frame_size,
            max_message_size=self.max_message_size,
            send_buffer_limit=self.send_buffer_limit,
            status_level=self.status_level,
            call_service_timeout=self.call_service_timeout,
            topics_glob=self.topics_glob,
            services_glob=self.services_glob,
        )

    def node_options(self) -> NodeOptions:
        return NodeOptions(
            map_store=self.map_store,
            slamware=self.slamware,
            authenticate=self.authenticate,
            time_scale=self.sim_speed if self.robot == "sim" else 1.0,
            topics_glob=self.topics_glob,
            services_glob=self.services_glob,
            params_glob=self.params_glob,
        )

    def robot_options(self) -> RobotOptions:
        return RobotOptions(
            robot=self.robot,
            world=self.world,
            sim_seed=self.sim_seed,
            sim_speed=self.sim_speed,
            sim_mapping=self.sim_mapping,
            reconn_wait_ms=self.slamware.reconn_wait_ms,
        )


_HELP = {
    "port": "WebSocket port (0 = pick a free one); plain HTTP GET on it serves the web UI",
    "address": "address to bind; 127.0.0.1 by default, use 0.0.0.0 to serve a robot LAN",
    "tcp_port": "raw TCP JSON port (one JSON object per line out); 0 = off, -1 = pick a free one",
    "authenticate": "require a valid rosauth 'auth' op before any other op",
    "auth_secret_file": "file whose first line is the 16-character rosauth secret",
    "fragment_timeout": "seconds an incomplete fragmented message is kept",
    "max_message_size": "fragment outgoing JSON ops longer than this many characters",
    "max_frame_size": "largest incoming WebSocket frame (and fragmented message) accepted, in "
    "bytes",
    "fragment_memory_limit": "bytes of incoming fragments held for all clients together",
    "delay_between_messages": "seconds to wait after each frame sent to a client",
    "unregister_timeout": "seconds an unused topic lingers before it is removed",
    "call_service_timeout": "default timeout of call_service in seconds (none = wait forever)",
    "topics_glob": "comma-separated fnmatch patterns of topics clients may use",
    "services_glob": "comma-separated fnmatch patterns of services clients may use",
    "params_glob": "comma-separated fnmatch patterns of parameters clients may use",
    "status_level": "initial status level of each client: info, warning, error or none",
    "send_buffer_limit": "bytes queued per client before its oldest topic messages are dropped",
    "use_compression": "offer WebSocket permessage-deflate",
    "websocket_ping_interval": "seconds between WebSocket pings to each client (0 = none)",
    "websocket_ping_timeout": "seconds a client has to answer a ping before it is disconnected",
    "ssl": "serve wss:// and TLS on the TCP port (needs --certfile)",
    "certfile": "PEM certificate chain for --ssl (may also hold the key)",
    "keyfile": "PEM private key for --ssl (if not in --certfile)",
    "log_level": "logging level: debug, info, warning, error",
    "robot": "the robot behind the bus: 'sim' (built-in simulated Slamware robot), 'none', or "
    "a Slamware REST URL such as http://192.168.11.1:1448",
    "world": "map_server YAML (+ PGM) the simulator drives in (default: the built-in office)",
    "sim_seed": "random seed of the simulator (sensor noise); same seed, same run",
    "sim_speed": "simulated seconds per wall-clock second (2 = twice as fast)",
    "sim_mapping": "start the simulator with an empty map and mapping on (not a prebuilt map)",
    "bus": "'local' (this process only) or 'zenoh' (share topics, services and actions with "
    "other servers and rmw_zenoh ROS 2 nodes on the same Zenoh network)",
    "zenoh_config": "Zenoh session config file (JSON5) for --bus zenoh; replaces the defaults "
    "(peer mode, no multicast scouting)",
    "zenoh_connect": "comma-separated Zenoh endpoints to connect to, e.g. tcp/127.0.0.1:7447",
    "zenoh_listen": "comma-separated Zenoh endpoints to listen on, e.g. tcp/127.0.0.1:7447",
    "zenoh_domain": "ROS domain id: the first chunk of every Zenoh key (as ROS_DOMAIN_ID)",
    "map_dir": "folder of saved map folders (default: $XDG_DATA_HOME/hitrobot-server/maps)",
    "state_dir": "folder of the robots' working state, one sub-folder per robot identity, "
    "written on every change and restored at start (default: "
    "$XDG_STATE_HOME/hitrobot-server)",
    "fresh": "start with a clean state: the robot's state folder is set aside, not read",
}

_SKIP = {"auth_secret", "client_tag", "slamware"}
ROBOTS = ("sim", "none")
BUSES = ("local", "zenoh")


# rosbridge_websocket's own names where they differ from ours (beyond '_' for '-').
_ROSBRIDGE_NAMES = {"call_service_timeout": "default_call_service_timeout"}


def flag_spellings(name: str) -> list[str]:
    """``--fragment-timeout`` and rosbridge's parameter spelling ``--fragment_timeout`` (and
    its own name where it differs), so a rosbridge user's command line works as it is."""
    spellings = ["--" + name.replace("_", "-"), "--" + name]
    if name in _ROSBRIDGE_NAMES:
        spellings.append("--" + _ROSBRIDGE_NAMES[name])
    return list(dict.fromkeys(spellings))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """One flag per Settings field, documented; defaults stay None so TOML can fill them."""
    parser.add_argument("--config", metavar="FILE", help="TOML file with the same settings")
    for f in fields(Settings):
        if f.name in _SKIP:
            continue
        flags = flag_spellings(f.name)
        default = f.default
        text = f"{_HELP[f.name]} (default: {default})"
        if f.type in ("bool", bool):
            parser.add_argument(
                *flags, dest=f.name, action=argparse.BooleanOptionalAction, default=None,
                help=text,
            )
            continue
        kind = _kind(f.type)
        kwargs: dict[str, Any] = {"type": kind, "default": None, "help": text, "dest": f.name}
        if f.name == "status_level":
            kwargs["choices"] = STATUS_LEVELS
        parser.add_argument(*flags, **kwargs)


def _kind(annotation: Any):
    text = str(annotation)
    if text.startswith("int"):
        return int
    if text.startswith("float"):
        return float
    return str


def load(args: argparse.Namespace) -> Settings:
    """Defaults < TOML file (``--config``) < explicit flags."""
    values: dict[str, Any] = {}
    if getattr(args, "config", None):
        data = tomllib.loads(Path(args.config).read_text())
        if "slamware" in data:
            values["slamware"] = SlamwareParams.from_mapping(data.pop("slamware"))
        section = data.get("server", data)
        known = {f.name for f in fields(Settings)} - _SKIP
        for key, value in section.items():
            name = key.replace("-", "_")
            if name not in known:
                raise ValueError(f"{args.config}: unknown setting '{key}'")
            values[name] = value
    for f in fields(Settings):
        if f.name in _SKIP:
            continue
        value = getattr(args, f.name, None)
        if value is not None:
            values[f.name] = value
    settings = Settings(**values)
    if settings.status_level not in STATUS_LEVELS:
        raise ValueError(f"status_level must be one of {', '.join(STATUS_LEVELS)}")
    if settings.robot not in ROBOTS and not settings.robot.startswith(("http://", "https://")):
        raise ValueError(f"robot must be {', '.join(ROBOTS)} or an http(s):// URL")
    if settings.bus not in BUSES:
        raise ValueError(f"bus must be one of {', '.join(BUSES)}")
    if settings.sim_speed <= 0:
        raise ValueError("sim_speed must be positive")
    if settings.ssl and not settings.certfile:
        raise ValueError("--ssl needs --certfile (and --keyfile unless the key is in it)")
    if settings.websocket_ping_interval < 0 or settings.websocket_ping_timeout <= 0:
        raise ValueError("websocket_ping_interval must be 0 or more and "
                         "websocket_ping_timeout positive")
    if settings.fragment_memory_limit < 1:
        raise ValueError("fragment_memory_limit must be positive")
    return settings

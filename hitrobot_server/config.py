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

from .bus.namespace import check_robot_name
from .nodes.assembly import reserved_names
from .nodes.options import NodeOptions, SlamwareParams
from .robot.options import RobotEntry, RobotOptions, parse_robot
from .session.options import SessionOptions
from .state import default_root as default_state_root

STATUS_LEVELS = ("info", "warning", "error", "none")
EVENT_LOOPS = ("auto", "uvloop", "asyncio")


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
    max_requests_in_flight: int = 1000
    topics_glob: str | None = None
    services_glob: str | None = None
    params_glob: str | None = None
    status_level: str = "error"
    send_buffer_limit: int = 10_000_000
    reply_buffer_limit: int = 16_000_000
    use_compression: bool = False
    websocket_ping_interval: float = 0.0
    websocket_ping_timeout: float = 30.0
    ssl: bool = False
    certfile: str | None = None
    keyfile: str | None = None
    tls_handshake_timeout: float = 5.0
    max_tls_handshakes: int = 64
    max_tls_handshakes_per_address: int = 8
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
    workers: str = "1"
    event_loop: str = "auto"
    record: str | None = None
    record_topics: str | None = None
    record_split_size: int = 0
    record_dir: str | None = None
    demo_services: bool = False
    slamware: SlamwareParams = field(default_factory=SlamwareParams)
    # Named robots (``--robot NAME=SPEC``, repeatable); empty: the single unnamed ``robot``.
    robots: tuple[RobotEntry, ...] = ()
    auth_secret: str | None = field(default=None, repr=False)
    # Set by the server when it shares a bus: client node names stay unique across servers.
    client_tag: str = field(default="", repr=False)
    # Set by the --workers parent for each worker it starts (hidden --worker-id flag): the
    # worker binds its ports with SO_REUSEPORT; worker 0 runs the robot and the nodes.
    worker_id: int | None = field(default=None, repr=False)

    @property
    def worker_count(self) -> int:
        """``--workers`` as a number: ``auto`` is the number of cores."""
        return (os.cpu_count() or 1) if self.workers == "auto" else int(self.workers)

    @property
    def primary(self) -> bool:
        """Runs the robot and the nodes: a lone server, or worker 0 of ``--workers``."""
        return self.worker_id in (None, 0)

    @property
    def map_store(self) -> Path:
        """Where map folders are saved: ``--map-dir`` or the per-user data directory."""
        return Path(self.map_dir) if self.map_dir else _user_data("maps")

    @property
    def recordings(self) -> Path:
        """Where ``/record/start`` writes and HTTP serves recordings from: ``--record-dir``
        or the per-user data directory."""
        return Path(self.record_dir) if self.record_dir else _user_data("recordings")

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
            reply_buffer_limit=self.reply_buffer_limit,
            status_level=self.status_level,
            call_service_timeout=self.call_service_timeout,
            max_requests_in_flight=self.max_requests_in_flight,
            topics_glob=self.topics_glob,
            services_glob=self.services_glob,
            params_glob=self.params_glob,
        )

    def robot_entries(self) -> list[RobotEntry]:
        """Every robot to attach: the named ones, or the single unnamed ``--robot``."""
        return list(self.robots) or [RobotEntry("", self.robot)]

    def node_options(self, robot: str | None = None) -> NodeOptions:
        """The nodes' options (for one robot's ``spec`` when given, else the unnamed one)."""
        spec = self.robot if robot is None else robot
        return NodeOptions(
            map_store=self.map_store,
            slamware=self.slamware,
            authenticate=self.authenticate,
            time_scale=self.sim_speed if spec == "sim" else 1.0,
            topics_glob=self.topics_glob,
            services_glob=self.services_glob,
            params_glob=self.params_glob,
            demo_services=self.demo_services,
        )

    def robot_options(self, entry: RobotEntry | None = None) -> RobotOptions:
        return RobotOptions(
            robot=self.robot if entry is None else entry.spec,
            start=None if entry is None else entry.start,
            world=self.world,
            sim_seed=self.sim_seed,
            sim_speed=self.sim_speed,
            sim_mapping=self.sim_mapping,
            reconn_wait_ms=self.slamware.reconn_wait_ms,
        )


def _user_data(name: str) -> Path:
    """``$XDG_DATA_HOME/hitrobot-server/NAME`` (``~/.local/share`` when unset)."""
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "hitrobot-server" / name


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
    "max_requests_in_flight": "service calls (and, separately, action goals) one client may have "
    "waiting for an answer; more are refused with a status",
    "topics_glob": "comma-separated fnmatch patterns of topics clients may use",
    "services_glob": "comma-separated fnmatch patterns of services clients may use",
    "params_glob": "comma-separated fnmatch patterns of parameters clients may use",
    "status_level": "initial status level of each client: info, warning, error or none",
    "send_buffer_limit": "bytes queued per client before its oldest topic messages are dropped",
    "reply_buffer_limit": "bytes of replies and statuses queued per client before its input "
    "is no longer read and its requests are refused; at twice this it is disconnected",
    "use_compression": "offer WebSocket permessage-deflate",
    "websocket_ping_interval": "seconds between WebSocket pings to each client (0 = none)",
    "websocket_ping_timeout": "seconds a client has to answer a ping before it is disconnected",
    "ssl": "serve wss:// and TLS on the TCP port (needs --certfile)",
    "certfile": "PEM certificate chain for --ssl (may also hold the key)",
    "keyfile": "PEM private key for --ssl (if not in --certfile)",
    "tls_handshake_timeout": "seconds a client has to finish the TLS handshake (--ssl), on "
    "both ports",
    "max_tls_handshakes": "TLS handshakes in progress at once, all clients together; a "
    "connection beyond it is closed at once",
    "max_tls_handshakes_per_address": "TLS handshakes in progress at once from one source "
    "address",
    "log_level": "logging level: debug, info, warning, error",
    "robot": "the robot behind the bus: 'sim' (built-in simulated Slamware robot), 'none', or "
    "a Slamware REST URL such as http://192.168.11.1:1448; repeat as NAME=SPEC for several "
    "robots, each under /NAME/ (sim@X,Y[,YAW] sets a simulated robot's start pose)",
    "world": "map_server YAML (+ PGM) the simulator drives in (default: the built-in office)",
    "sim_seed": "random seed of the simulator (sensor noise); same seed, same run",
    "sim_speed": "simulated seconds per wall-clock second (2 = twice as fast)",
    "sim_mapping": "start the simulator with an empty map and mapping on (not a prebuilt map)",
    "bus": "'local' (this process only) or 'zenoh' (share topics, services and actions with "
    "other servers and rmw_zenoh ROS 2 nodes on the same Zenoh network)",
    "zenoh_config": "Zenoh session config file (JSON5) for --bus zenoh; replaces the defaults "
    "(peer mode, no multicast scouting)",
    "zenoh_connect": "comma-separated Zenoh endpoints to connect to, e.g. tcp/127.0.0.1:7447",
    "zenoh_listen": "comma-separated Zenoh endpoints to listen on, e.g. tcp/127.0.0.1:7447 "
    "(default: tcp/127.0.0.1:0, any free loopback port)",
    "zenoh_domain": "ROS domain id: the first chunk of every Zenoh key (as ROS_DOMAIN_ID)",
    "workers": "server processes behind the same ports (SO_REUSEPORT), joined over Zenoh "
    "(needs the [zenoh] extra); 'auto' = one per core; 1 = this process alone",
    "event_loop": "'auto' (uvloop when installed, the [uvloop] extra, except with --ssl), "
    "'uvloop' or 'asyncio'",
    "record": "record every bus message into this MCAP file (ROS 2 profile: CDR messages, "
    "ros2msg schemas, zstd chunks) while serving, with an audit channel of client ops",
    "record_topics": "comma-separated fnmatch patterns of topics to record (default: all)",
    "record_split_size": "start a new file (NAME_1.mcap, ...) when a recording reaches this many "
    "MiB (0 = never)",
    "record_dir": "folder of /record/start's recordings, downloadable at /recordings/NAME "
    "(default: $XDG_DATA_HOME/hitrobot-server/recordings)",
    "map_dir": "folder of saved map folders (default: $XDG_DATA_HOME/hitrobot-server/maps)",
    "demo_services": "offer the tutorial servers of the rosbridge test image: the service "
    "/add_two_ints and the action /fibonacci (example_interfaces types), for client test suites",
    "state_dir": "folder of the robots' working state, one sub-folder per robot identity, "
    "written on every change and restored at start (default: "
    "$XDG_STATE_HOME/hitrobot-server)",
    "fresh": "start with a clean state: the robot's state folder is set aside, not read",
}

_SKIP = {"auth_secret", "client_tag", "slamware", "worker_id", "robots"}
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
        text = _HELP[f.name]
        if "(default:" not in text:  # a help text may say the default better than the value
            shown = ("none" if f.default is None else ("on" if f.default else "off")
                     if isinstance(f.default, bool) else f.default)
            text += f" (default: {shown})"
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
        if f.name == "event_loop":
            kwargs["choices"] = EVENT_LOOPS
        if f.name == "robot":  # repeatable: --robot a=sim --robot b=sim
            kwargs["action"] = "append"
        parser.add_argument(*flags, **kwargs)
    parser.add_argument("--worker-id", type=int, default=None, help=argparse.SUPPRESS)


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
        if "robots" in data:  # [robots] NAME = "SPEC"
            table = data.pop("robots")
            if not isinstance(table, dict) or not all(isinstance(v, str) for v in table.values()):
                raise ValueError(f"{args.config}: [robots] maps robot names to SPEC strings")
            values["robot"] = [f"{name}={spec}" for name, spec in table.items()]
        section = data.get("server", data)
        known = {f.name for f in fields(Settings)} - _SKIP
        for key, value in section.items():
            name = key.replace("-", "_")
            if name not in known:
                raise ValueError(f"{args.config}: unknown setting '{key}'")
            if name == "robot" and "robot" in values:
                raise ValueError(f"{args.config}: give the robots either as 'robot' or as a "
                                 "[robots] table, not both")
            values[name] = value
    for f in fields(Settings):
        if f.name in _SKIP:
            continue
        value = getattr(args, f.name, None)
        if value is not None:
            values[f.name] = value
    if "robot" in values:
        values["robot"], values["robots"] = robot_entries(values["robot"])
    settings = Settings(**values)
    settings.worker_id = getattr(args, "worker_id", None)
    settings.workers = str(settings.workers)
    if settings.workers != "auto" and not (
        settings.workers.isdigit() and int(settings.workers) >= 1
    ):
        raise ValueError("workers must be a whole number of at least 1, or auto")
    if settings.event_loop not in EVENT_LOOPS:
        raise ValueError(f"event_loop must be one of {', '.join(EVENT_LOOPS)}")
    if settings.ssl and settings.event_loop == "uvloop":
        raise ValueError("--ssl runs on asyncio's event loop: uvloop's start_tls loses TLS "
                         "handshakes taken over from a paused connection (use --event-loop "
                         "auto or asyncio)")
    if settings.ssl and settings.event_loop == "auto":
        settings.event_loop = "asyncio"  # the TLS handshake gate needs asyncio's start_tls
    if settings.status_level not in STATUS_LEVELS:
        raise ValueError(f"status_level must be one of {', '.join(STATUS_LEVELS)}")
    if settings.bus not in BUSES:
        raise ValueError(f"bus must be one of {', '.join(BUSES)}")
    if settings.sim_speed <= 0:
        raise ValueError("sim_speed must be positive")
    if settings.ssl and not settings.certfile:
        raise ValueError("--ssl needs --certfile (and --keyfile unless the key is in it)")
    if settings.websocket_ping_interval < 0 or settings.websocket_ping_timeout <= 0:
        raise ValueError("websocket_ping_interval must be 0 or more and "
                         "websocket_ping_timeout positive")
    if settings.record_split_size < 0:
        raise ValueError("record_split_size must be 0 or more (MiB)")
    if settings.tls_handshake_timeout <= 0:
        raise ValueError("tls_handshake_timeout must be positive")
    if settings.max_tls_handshakes < 1 or settings.max_tls_handshakes_per_address < 1:
        raise ValueError("max_tls_handshakes and max_tls_handshakes_per_address must be "
                         "positive")
    if settings.max_requests_in_flight < 1:
        raise ValueError("max_requests_in_flight must be positive")
    if settings.fragment_memory_limit < 1:
        raise ValueError("fragment_memory_limit must be positive")
    return settings


def robot_entries(given: str | list[str]) -> tuple[str, tuple[RobotEntry, ...]]:
    """``--robot`` occurrences (or the TOML value) → the unnamed robot's spec and the named
    robots. Every name is checked before anything starts: one unnamed robot or only named ones,
    no duplicates, no name that is invalid or shadows a global name."""
    texts = [given] if isinstance(given, str) else list(given)
    if not texts or not all(isinstance(t, str) for t in texts):
        raise ValueError("robot must be a SPEC string or a list of NAME=SPEC strings")
    entries = [parse_robot(t) for t in texts]
    named = [e for e in entries if e.name]
    if not named:
        if len(entries) > 1:
            raise ValueError("several robots need names: --robot NAME=SPEC for each")
        only = entries[0]
        if only.start is not None:
            raise ValueError("a start pose (sim@X,Y) needs a named robot: --robot NAME=sim@X,Y")
        return only.spec, ()
    if len(named) != len(entries):
        raise ValueError("name every robot (--robot NAME=SPEC) when there are several")
    seen: set[str] = set()
    for entry in named:
        check_robot_name(entry.name, reserved_names())
        if entry.name in seen:
            raise ValueError(f"robot name {entry.name!r} is given twice")
        seen.add(entry.name)
    return "sim", tuple(named)

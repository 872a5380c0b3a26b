"""Server settings: each layer's options composed, filled from defaults, a TOML file, then
command-line flags (defaults < TOML < flags).

Each layer declares its own settings in its options dataclass (``TransportOptions``,
``SessionOptions``, ``BusOptions``, ``RobotOptions``, ``NodeOptions``, ``StoreOptions``,
``RecordOptions``, and :class:`ProcessOptions` here): a field with a ``help`` in its metadata is
a setting, its default the server's, its checks the class's ``check``. This module only
composes them into :class:`Settings` and makes one flag per setting, in :data:`FLAG_ORDER`.
Flag names follow rosbridge_websocket's parameters so a rosbridge user finds them.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from .bus.namespace import check_robot_name
from .bus.options import BusOptions
from .nodes.assembly import reserved_names
from .nodes.options import NodeOptions, SlamwareParams
from .record.options import RecordOptions
from .robot.options import RobotEntry, RobotOptions, parse_robot
from .session.options import SessionOptions
from .state.options import StoreOptions
from .transport.options import TransportOptions
from .vda5050.options import Vda5050Options

EVENT_LOOPS = ("auto", "uvloop", "asyncio")


@dataclass(frozen=True)
class ProcessOptions:
    """How the server process runs: its log, its event loop, its worker processes."""

    log_level: str = field(default="info", metadata={
        "help": "logging level: debug, info, warning, error"})
    workers: str = field(default="1", metadata={
        "help": "server processes behind the same ports (SO_REUSEPORT), joined over Zenoh "
        "(needs the [zenoh] extra); 'auto' = one per core; 1 = this process alone"})
    event_loop: str = field(default="auto", metadata={
        "help": "'auto' (uvloop, a dependency where it runs, except with --ssl), "
        "'uvloop' or 'asyncio'", "choices": EVENT_LOOPS})

    def __post_init__(self) -> None:
        object.__setattr__(self, "workers", str(self.workers))  # TOML may give a number

    @property
    def worker_count(self) -> int:
        """``--workers`` as a number: ``auto`` is the number of cores."""
        return (os.cpu_count() or 1) if self.workers == "auto" else int(self.workers)

    def check(self) -> None:
        if self.workers != "auto" and not (self.workers.isdigit() and int(self.workers) >= 1):
            raise ValueError("workers must be a whole number of at least 1, or auto")
        if self.event_loop not in EVENT_LOOPS:
            raise ValueError(f"event_loop must be one of {', '.join(EVENT_LOOPS)}")


# Every layer's options, by the name Settings knows them under. NodeOptions comes last: it is
# handed settings of the others (the map folder, the access rules, [slamware]).
SECTIONS: dict[str, type] = {
    "transport": TransportOptions, "session": SessionOptions, "bus": BusOptions,
    "robot": RobotOptions, "store": StoreOptions, "record": RecordOptions,
    "process": ProcessOptions, "vda5050": Vda5050Options, "nodes": NodeOptions,
}

# The flags in --help order (and the TOML keys): each is a field with a help text in one of
# the SECTIONS.
FLAG_ORDER = (
    "port", "address", "tcp_port", "authenticate", "auth_secret_file", "tokens_file", "roles",
    "fragment_timeout",
    "max_message_size", "max_frame_size", "fragment_memory_limit", "delay_between_messages",
    "unregister_timeout", "call_service_timeout", "max_requests_in_flight", "topics_glob",
    "services_glob", "params_glob", "status_level", "send_buffer_limit", "send_window",
    "reply_buffer_limit",
    "use_compression", "websocket_ping_interval", "websocket_ping_timeout", "ssl", "certfile",
    "keyfile", "tls_handshake_timeout", "max_tls_handshakes", "max_tls_handshakes_per_address",
    "log_level", "robot", "world", "sim_seed", "sim_speed", "sim_mapping", "map_dir",
    "state_dir", "fresh", "bus", "zenoh_config", "zenoh_connect", "zenoh_listen",
    "zenoh_domain", "workers", "event_loop", "record", "record_topics", "record_split_size",
    "record_split_time", "record_max_disk", "record_dir", "black_box", "black_box_max_mb",
    "black_box_localization", "demo_services", "charge_below", "charge_until", "site_timezone",
    "site_map_robot", "vda5050", "vda5050_manufacturer", "vda5050_serial", "vda5050_interface",
    "vda5050_password_file", "vda5050_ca_file", "vda5050_cert_file", "vda5050_key_file",
)


def declared(kind: type) -> dict[str, dataclasses.Field]:
    """The settings an options class declares: its fields with a help text."""
    return {f.name: f for f in fields(kind) if "help" in f.metadata}


def setting_fields() -> dict[str, tuple[str, dataclasses.Field]]:
    """Every setting's name → the section that declares it and its field."""
    return {name: (section, f) for section, kind in SECTIONS.items()
            for name, f in declared(kind).items()}


@dataclass(frozen=True)
class Settings:
    """Every layer's options, composed; build it with :meth:`of` (or :func:`load`)."""

    transport: TransportOptions
    session: SessionOptions
    bus: BusOptions
    robot: RobotOptions
    store: StoreOptions
    record: RecordOptions
    process: ProcessOptions
    vda5050: Vda5050Options
    nodes: NodeOptions
    # Named robots (``--robot NAME=SPEC``, repeatable); empty: the single unnamed ``robot``.
    robots: tuple[RobotEntry, ...] = ()
    # Given by the --workers parent to each worker it starts (hidden --worker-id flag): the
    # worker binds its ports with SO_REUSEPORT; worker 0 runs the robot and the nodes.
    worker_id: int | None = None

    @classmethod
    def of(cls, *, slamware: SlamwareParams | None = None, robots: tuple[RobotEntry, ...] = (),
           worker_id: int | None = None, **values: Any) -> Settings:
        """From settings by name (the flags' and the TOML keys'), each handed to the layer
        that declares it; every other setting keeps its layer's default."""
        owner = setting_fields()
        if unknown := [name for name in values if name not in owner]:
            raise TypeError(f"unknown settings: {', '.join(unknown)}")
        given: dict[str, dict[str, Any]] = {section: {} for section in SECTIONS}
        for name, value in values.items():
            given[owner[name][0]][name] = value
        slamware = slamware or SlamwareParams()
        parts = {section: kind(**given[section]) for section, kind in SECTIONS.items()
                 if kind not in (RobotOptions, NodeOptions)}
        parts["robot"] = RobotOptions(**given["robot"], reconn_wait_ms=slamware.reconn_wait_ms)
        session = parts["session"]
        parts["nodes"] = NodeOptions(
            **given["nodes"], map_store=parts["store"].map_store, slamware=slamware,
            authenticate=session.authenticate, topics_glob=session.topics_glob,
            services_glob=session.services_glob, params_glob=session.params_glob,
        )
        return cls(**parts, robots=tuple(robots), worker_id=worker_id)

    @property
    def event_loop(self) -> str:
        """The event loop to run: ``--event-loop``, but asyncio's for ``auto`` with --ssl (the
        TLS handshake gate needs asyncio's start_tls)."""
        loop = self.process.event_loop
        return "asyncio" if self.transport.ssl and loop == "auto" else loop

    def check(self) -> None:
        """Refuse settings that cannot work: each layer checks its own, and --ssl refuses
        uvloop (``ValueError`` naming the setting)."""
        self.process.check()
        if self.transport.ssl and self.process.event_loop == "uvloop":
            raise ValueError("--ssl runs on asyncio's event loop: uvloop's start_tls loses TLS "
                             "handshakes taken over from a paused connection (use --event-loop "
                             "auto or asyncio)")
        for part in (self.session, self.bus, self.robot, self.transport, self.record,
                     self.vda5050):
            part.check()
        self.check_site_map()

    def check_site_map(self) -> None:
        """``--site-map-robot`` names one of the named robots, one that has a map."""
        chosen = self.nodes.site_map_robot
        if not chosen:
            return
        entry = next((e for e in self.robots if e.name == chosen), None)
        if entry is None:
            names = ", ".join(e.name for e in self.robots) or "none: a single robot has no site"
            raise ValueError(f"--site-map-robot {chosen!r} is not one of the robots ({names})")
        if entry.spec == "none":
            raise ValueError(f"--site-map-robot {chosen!r}: robot {chosen!r} is 'none', it "
                             "has no map")

    def robot_entries(self) -> list[RobotEntry]:
        """Every robot to attach: the named ones, or the single unnamed ``--robot``."""
        return list(self.robots) or [RobotEntry("", self.robot.robot)]

    def node_options(self, robot: str | None = None) -> NodeOptions:
        """The nodes' options (for one robot's ``spec`` when given, else the unnamed one)."""
        spec = self.robot.robot if robot is None else robot
        return dataclasses.replace(
            self.nodes, time_scale=self.robot.sim_speed if spec == "sim" else 1.0)

    def robot_options(self, entry: RobotEntry | None = None) -> RobotOptions:
        """One robot's options: the unnamed robot's, or ``entry``'s spec and start pose."""
        if entry is None:
            return self.robot
        return dataclasses.replace(self.robot, robot=entry.spec, start=entry.start)


# rosbridge_websocket's own names where they differ from ours (beyond '_' for '-').
_ROSBRIDGE_NAMES = {"call_service_timeout": "default_call_service_timeout"}


def flag_spellings(name: str) -> list[str]:
    """``--fragment-timeout`` and rosbridge's parameter spelling ``--fragment_timeout`` (and
    its own name where it differs), so a rosbridge user's command line works as it is."""
    spellings = ["--" + name.replace("_", "-"), "--" + name]
    if name in _ROSBRIDGE_NAMES:
        spellings.append("--" + _ROSBRIDGE_NAMES[name])
    return list(dict.fromkeys(spellings))


def shown_default(f: dataclasses.Field) -> str:
    """A setting's help text, with its default (from its field) unless the text says it."""
    text = f.metadata["help"]
    if "(default:" in text:  # a help text may say the default better than the value
        return text
    value = f.default
    shown = ("none" if value is None else ("on" if value else "off")
             if isinstance(value, bool) else value)
    return f"{text} (default: {shown})"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """One flag per setting, documented; defaults stay None so TOML can fill them."""
    parser.add_argument("--config", metavar="FILE", help="TOML file with the same settings")
    owner = setting_fields()
    for name in FLAG_ORDER:
        f = owner[name][1]
        kwargs: dict[str, Any] = {"dest": name, "default": None, "help": shown_default(f)}
        if f.type in ("bool", bool):
            kwargs["action"] = argparse.BooleanOptionalAction
        else:
            kwargs["type"] = _kind(f.type)
            if "choices" in f.metadata:
                kwargs["choices"] = f.metadata["choices"]
            if f.metadata.get("repeatable"):  # --robot a=sim --robot b=sim
                kwargs["action"] = "append"
        parser.add_argument(*flag_spellings(name), **kwargs)
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
    values = toml_values(args.config) if getattr(args, "config", None) else {}
    for name in FLAG_ORDER:
        value = getattr(args, name, None)
        if value is not None:
            values[name] = value
    if "robot" in values:
        values["robot"], values["robots"] = robot_entries(values["robot"])
    settings = Settings.of(**values, worker_id=getattr(args, "worker_id", None))
    settings.check()
    return settings


def toml_values(path: str) -> dict[str, Any]:
    """The settings of a TOML file: ``[server]`` (or the top level), ``[slamware]``, and
    ``[robots]`` (NAME = "SPEC"); an unknown key is an error naming it."""
    data = tomllib.loads(Path(path).read_text())
    values: dict[str, Any] = {}
    if "slamware" in data:
        values["slamware"] = SlamwareParams.from_mapping(data.pop("slamware"))
    if "robots" in data:  # [robots] NAME = "SPEC"
        table = data.pop("robots")
        if not isinstance(table, dict) or not all(isinstance(v, str) for v in table.values()):
            raise ValueError(f"{path}: [robots] maps robot names to SPEC strings")
        values["robot"] = [f"{name}={spec}" for name, spec in table.items()]
    for key, value in data.get("server", data).items():
        name = key.replace("-", "_")
        if name not in FLAG_ORDER:
            raise ValueError(f"{path}: unknown setting '{key}'")
        if name == "robot" and "robot" in values:
            raise ValueError(f"{path}: give the robots either as 'robot' or as a [robots] "
                             "table, not both")
        values[name] = value
    return values


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

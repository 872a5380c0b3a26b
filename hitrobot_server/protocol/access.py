"""Who may do what: the roles, the permission each op on each name needs, and the one check
every protocol calls before it acts (sans-I/O: :func:`allowed` is a pure function).

An op is a kind (:data:`KINDS`) and a name (a topic, service, action, parameter or HTTP path).
:func:`permission` classifies it by the first matching pattern of a table; :func:`allowed`
says whether a role holds that permission and, for a role with limits (``agent``), whether the
parsed message stays inside them. A name under a robot namespace (``/r1/cmd_vel``) matches the
same patterns, which all begin with ``*``.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from typing import Any

WHOAMI = "/hitrobot/whoami"
"""The service that tells a client its token's name, role and permissions (every role)."""
WHOAMI_NODE = "/hitrobot_access"
"""The node serving it: both are global names no robot may take."""

KINDS = ("subscribe", "publish", "call", "provide", "goal", "cancel", "param_get",
         "param_set", "playback", "http")
"""What a client does: receive a topic, publish (or advertise) one, call a service, offer a
service or action, send an action goal, cancel one, read or write parameters, control a
replay's timeline, or ask an HTTP path."""

PERMISSIONS = {
    "read": "subscribe, call read-only services, read parameters",
    "console": "load the web console",
    "download": "download recordings",
    "metrics": "scrape /metrics and /healthz",
    "drive": "publish velocity commands (/cmd_vel)",
    "moves": "the robot's own moves (move_to, rotate, go_home, ...)",
    "goals": "navigation goals and actions",
    "cancel": "pause, resume and cancel goals",
    "localize": "set the robot's pose",
    "pois": "add, change and delete POIs",
    "walls": "virtual walls, lines, masks and zones",
    "patrols": "waypoints and patrols",
    "dispatch": "fleet tasks and schedules",
    "record": "start and stop recordings, replays and their timeline",
    "publish": "publish to other topics",
    "call": "call services other clients provide",
    "provide": "offer services and actions",
    "maps": "load, save, build and clear maps",
    "settings": "robot settings and simulator controls",
    "shell": "/cmd_string commands",
    "params": "write parameters",
    "tokens": "manage tokens",
    "whoami": "ask who it is (every role)",
}

_VIEWER = frozenset({"read", "console", "download", "metrics"})
_OPERATOR = _VIEWER | {"drive", "moves", "goals", "cancel", "localize", "pois", "walls",
                       "patrols", "dispatch", "record", "publish", "call", "provide"}
_ADMIN = _OPERATOR | {"maps", "settings", "shell", "params", "tokens"}
_AGENT = frozenset({"read", "console", "drive", "goals", "cancel"})


@dataclass(frozen=True)
class Limits:
    """What an ``agent`` may not exceed: its speed on ``/cmd_vel`` (m/s and rad/s) and the
    zones (``[x0, y0, x1, y1]`` in the map frame) its pose goals must fall in."""

    max_speed: float = 0.3
    max_turn: float = 0.5
    zones: tuple[tuple[float, float, float, float], ...] = ()


@dataclass(frozen=True)
class Role:
    name: str
    permissions: frozenset[str]
    limits: Limits | None = None  # None: unconstrained within its permissions


ROLES: dict[str, Role] = {
    "monitor": Role("monitor", frozenset({"metrics"})),
    "viewer": Role("viewer", _VIEWER),
    "operator": Role("operator", _OPERATOR),
    "admin": Role("admin", _ADMIN),
    "agent": Role("agent", _AGENT, Limits()),
}
"""The built-in roles; ``--roles FILE`` replaces or adds roles (:func:`roles_from`)."""

NOBODY = Role("none", frozenset())
"""A client not authenticated (yet) on a server with ``--authenticate``."""


@dataclass(frozen=True)
class Grant:
    """Who a client is: the token's name and its role (the role's name)."""

    name: str
    role: str


# (op kinds, name pattern, permission): the first row whose kind and pattern match decides.
# Patterns are fnmatch's (``*`` crosses ``/``). A service or topic of the server's own that no
# row names falls to the last rows: tests/protocol/test_access.py checks there is none.
_READ_SERVICES = ("/rosapi/*", "*/get_parameters", "*/list_parameters",
                  "*/describe_parameters", "*/get_pois", "/list_map_files",
                  "*/list_waypoints_files", "/record/list", "/republish_tfs",
                  "*/sync_get_stcm", "*/compute_path_to_pose*",
                  "*/_action/get_result", "/fleet/policy", "/fleet/history",
                  "/fleet/schedule_list", "/fleet/zone_list")
RULES: tuple[tuple[frozenset[str], str, str], ...] = tuple(
    (frozenset(kinds.split()), pattern, perm) for kinds, pattern, perm in [
        ("call", "*/hitrobot/whoami", "whoami"),
        ("subscribe", "*", "read"),
        ("param_get", "*", "read"),
        ("param_set", "*", "params"),
        ("playback", "*", "record"),
        ("provide", "*", "provide"),
        ("call", "/rosapi/set_param", "params"),
        ("call", "/rosapi/delete_param", "params"),
        ("call", "*/set_parameters", "params"),
        *(("call", p, "read") for p in _READ_SERVICES),
        ("goal cancel", "*/tf2_web_republisher", "read"),
        ("goal cancel", "*/compute_path_to_pose", "read"),
        ("publish", "*/tf2_web_republisher/goal", "read"),
        ("publish", "*/tf2_web_republisher/cancel", "read"),
        ("cancel", "*", "cancel"),
        ("call", "*/_action/cancel_goal", "cancel"),
        ("goal", "*", "goals"),
        ("call", "*/_action/send_goal", "goals"),
        ("publish", "*/cmd_vel", "drive"),
        ("call", "*/drive_lease/take", "drive"),  # the node lets only an admin take over
        ("publish", "*/cmd_string", "shell"),
        ("publish", "*/move_base/cancel", "cancel"),
        ("publish", "*/cancel_action", "cancel"),
        ("publish call", "*/planning/resume_patrol", "patrols"),
        ("publish", "*/move_base_simple/goal", "goals"),
        ("publish", "*/move_base/goal", "goals"),
        ("publish call", "*/navigation/*", "goals"),
        ("publish call", "*/graph/navigate_to_node", "goals"),
        ("publish call", "*/map_manager/*_poi", "pois"),
        ("publish call", "*/map_manager/modify_map", "walls"),
        ("publish call", "*/map_manager/*", "maps"),
        ("publish", "*/slamware_ros_sdk_server_node/*_line", "walls"),
        ("publish", "*/slamware_ros_sdk_server_node/*_lines", "walls"),
        ("publish", "*/slamware_ros_sdk_server_node/set_pose", "localize"),
        ("publish", "*/initialpose", "localize"),
        ("publish", "*/tf", "localize"),
        ("publish", "*/tf_static", "localize"),
        ("publish", "*/map", "maps"),
        ("call", "*/set_initialpose", "localize"),
        ("publish", "*/slamware_ros_sdk_server_node/recover_localization", "localize"),
        ("publish", "*/slamware_ros_sdk_server_node/*map*", "maps"),
        ("call", "*/slamware_ros_sdk_server_node/sync_set_stcm", "maps"),
        ("publish", "*/slamware_ros_sdk_server_node/*", "moves"),
        ("call", "*/load_laser_map", "maps"),
        ("call", "*/set_map", "maps"),
        ("call", "*/load_graph_file", "maps"),
        ("call", "*/save_graph_file", "maps"),
        ("call", "*/planning/*", "patrols"),
        ("call", "/fleet/zone*", "walls"),
        ("call", "/fleet/cancel", "cancel"),
        ("call", "/fleet/pause", "cancel"),
        ("call", "/fleet/resume", "cancel"),
        ("call", "/fleet/*", "dispatch"),
        ("call", "*/record/*", "record"),
        ("call", "*/sim/*", "settings"),
        ("call", "*/sit_down", "settings"),
        ("call", "*/stand_up", "settings"),
        ("call", "*/set_listen", "settings"),
        ("http", "/metrics", "metrics"),
        ("http", "/healthz", "metrics"),
        ("http", "/recordings/*", "download"),
        ("http", "*", "console"),
        ("publish", "*", "publish"),
        ("call", "*", "call"),
    ]
)


@functools.lru_cache(maxsize=4096)
def permission(kind: str, name: str) -> str:
    """The permission an op of ``kind`` on ``name`` needs (:data:`RULES`)."""
    for kinds, pattern, perm in RULES:
        if kind in kinds and fnmatchcase(name, pattern):
            return perm
    raise ValueError(f"unknown op kind {kind!r}")


def allowed(role: Role, kind: str, name: str, message: Any = None) -> str | None:
    """None when ``role`` may do ``kind`` on ``name`` (with the parsed ``message`` it carries,
    for a role with limits); else the reason, naming the role and the missing permission."""
    perm = permission(kind, name)
    if perm not in role.permissions and perm != "whoami":
        having = ", ".join(r.name for r in ROLES.values() if perm in r.permissions)
        return (f"role '{role.name}' lacks the permission '{perm}' "
                f"({PERMISSIONS.get(perm, perm)}) needed to {kind} {name}"
                + (f" (built-in roles with it: {having})" if having else ""))
    if role.limits is not None and (message is not None or kind in ("call", "goal")):
        return _within_limits(role, perm, name, message)  # a goal without its pose: refused
    return None


def _within_limits(role: Role, perm: str, name: str, message: Any) -> str | None:
    """An agent's commands: refused (not clamped) past its speed; pose goals outside its zones
    refused (a goal to a POI by name is always inside)."""
    limits = role.limits
    assert limits is not None
    if perm == "drive" and isinstance(message, Mapping):
        speed, turn = _twist(message)
        if speed > limits.max_speed or turn > limits.max_turn:
            return (f"role '{role.name}' may drive at most {limits.max_speed} m/s and "
                    f"{limits.max_turn} rad/s; {name} asked {speed:.3g} m/s, "
                    f"{turn:.3g} rad/s: refused")
    if perm == "goals" and not name.endswith("/navigate_to_poi"):
        point = goal_point(message)
        if point is None:
            return (f"role '{role.name}' may send goals only to a POI (navigate_to_poi) or "
                    f"to a pose inside its zones; {name} carries no pose")
        if not any(_inside(point, zone) for zone in limits.zones):
            return (f"role '{role.name}' may send goals only inside its zones; ({point[0]:.3g}, "
                    f"{point[1]:.3g}) on {name} is outside them")
    return None


def _twist(message: Mapping) -> tuple[float, float]:
    """The planar speed and the turn rate a Twist asks (a value not a finite number counts
    as infinite: refused)."""
    def num(part: str, axis: str) -> float:
        vector = message.get(part, {})
        value = vector.get(axis, 0.0) if isinstance(vector, Mapping) else math.inf
        try:
            value = abs(float(value))
        except (TypeError, ValueError):
            return math.inf
        return value if math.isfinite(value) else math.inf
    return math.hypot(num("linear", "x"), num("linear", "y")), num("angular", "z")


def goal_point(message: Any, depth: int = 0) -> tuple[float, float] | None:
    """The (x, y) of a goal message's pose (PoseStamped, MoveBase's goal, a Nav2 goal: the
    pose is nested under ``goal``, ``target_pose`` or ``pose``), None without one."""
    if not isinstance(message, Mapping) or depth > 6:
        return None
    position = message.get("position")
    if isinstance(position, Mapping):
        try:
            x, y = float(position.get("x", 0.0)), float(position.get("y", 0.0))
        except (TypeError, ValueError):
            return None
        return (x, y) if math.isfinite(x) and math.isfinite(y) else None
    for key in ("goal", "target_pose", "pose"):
        found = goal_point(message.get(key), depth + 1)
        if found is not None:
            return found
    return None


def _inside(point: tuple[float, float], zone: tuple[float, float, float, float]) -> bool:
    x0, y0, x1, y1 = zone
    return min(x0, x1) <= point[0] <= max(x0, x1) and min(y0, y1) <= point[1] <= max(y0, y1)


def rosauth_role(level: str) -> str:
    """The role of a rosauth MAC's ``level``: ``admin`` is admin, any other level operator."""
    return "admin" if level == "admin" else "operator"


@dataclass(frozen=True)
class RoleTable:
    """The roles a server knows, by name."""

    roles: Mapping[str, Role] = field(default_factory=lambda: dict(ROLES))

    def get(self, name: str | None) -> Role:
        """The role called ``name``; :data:`NOBODY` for None or a name the table lacks."""
        return self.roles.get(name or "", NOBODY)


def roles_from(text: str) -> RoleTable:
    """The built-in roles with those a ``--roles`` JSON file declares (each replaces or adds
    one): ``{"ROLE": {"permissions": [...], "max_speed": 0.3, "max_turn": 0.5,
    "zones": [[x0, y0, x1, y1], ...]}}`` (the limits make it a constrained role, as agent).
    Raises ``ValueError`` naming what is wrong."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"roles file: not JSON: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError("roles file: expected an object of roles")
    roles = dict(ROLES)
    for name, spec in data.items():
        roles[name] = _role_of(name, spec)
    return RoleTable(roles)


def _role_of(name: str, spec: Any) -> Role:
    if not isinstance(spec, dict) or not isinstance(spec.get("permissions"), list):
        raise ValueError(f"roles file: role {name!r} needs a 'permissions' list")
    unknown = [p for p in spec["permissions"] if p not in PERMISSIONS]
    if unknown:
        raise ValueError(f"roles file: role {name!r}: unknown permission(s) {unknown}; "
                         f"known: {', '.join(PERMISSIONS)}")
    limited = {"max_speed", "max_turn", "zones"} & spec.keys()
    limits = None
    if limited:
        try:
            zones = tuple(tuple(float(v) for v in z) for z in spec.get("zones", ()))
            if any(len(z) != 4 for z in zones):
                raise ValueError("a zone is [x0, y0, x1, y1]")
            limits = Limits(float(spec.get("max_speed", Limits.max_speed)),
                            float(spec.get("max_turn", Limits.max_turn)), zones)  # type: ignore
        except (TypeError, ValueError) as exc:
            raise ValueError(f"roles file: role {name!r}: bad limits: {exc}") from None
    return Role(name, frozenset(spec["permissions"]), limits)

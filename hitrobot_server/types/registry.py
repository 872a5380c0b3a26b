"""Message, service and action type registry.

rosbags' ROS 1 Noetic store supplies the common message packages; the interface files under
``schemas/`` add what it lacks (std_srvs, rosapi, nav2 actions, ...). Everything is registered
into one rosbags typestore so the same store can also serialise ROS 1 wire bytes (cbor-raw).

Names are canonical ROS 2 style inside the process (``pkg/msg/Type``, ``pkg/srv/Type_Request``,
``pkg/action/Type_Goal``); :meth:`TypeRegistry.short` gives the ROS 1 spelling for the wire.
"""

from __future__ import annotations

import re
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from .aliases import TYPE_ALIASES

HEADER = "std_msgs/msg/Header"
# rosbags models ROS 1 time/duration as builtin_interfaces messages; we treat them as base types.
ROSBAGS_TIME_TYPES = {
    "time": "builtin_interfaces/msg/Time",
    "duration": "builtin_interfaces/msg/Duration",
}
_TIME_TYPES = {msg: base for base, msg in ROSBAGS_TIME_TYPES.items()}
# numpy element type of each numeric base type (arrays handed to rosbags' serialisers)
NUMPY_DTYPES: dict[str, type[np.generic]] = {
    "bool": np.bool_,
    "int8": np.int8,
    "byte": np.int8,
    "uint8": np.uint8,
    "char": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}
# rosbags' code generator gives empty messages this dummy member; it is never on the wire.
_PLACEHOLDER = "structure_needs_at_least_one_member"
_SEPARATOR = re.compile(r"^[ \t]*---[ \t]*\r?$", re.MULTILINE)
_PART_SUFFIXES = {
    "srv": ("_Request", "_Response"),
    "action": ("_Goal", "_Result", "_Feedback"),
}

_Typesdict = dict[str, Any]


@dataclass(frozen=True, slots=True)
class Field:
    """One field of a message type.

    ``type`` is a base type name (``time``/``duration`` included) or a canonical message name;
    ``array`` is None for a scalar, 0 for a variable-length array, N for a fixed length N.
    """

    name: str
    type: str
    is_msg: bool
    array: int | None


@dataclass(frozen=True, slots=True)
class MsgType:
    """A message type with its fields in wire order."""

    name: str
    fields: tuple[Field, ...]
    constants: tuple[tuple[str, str, object], ...]
    has_header: bool


@dataclass(frozen=True, slots=True)
class SrvType:
    """A service: ``pkg/srv/Type`` with its ``_Request``/``_Response`` message types."""

    name: str
    request: MsgType
    response: MsgType


@dataclass(frozen=True, slots=True)
class ActionType:
    """An action: ``pkg/action/Type`` with its ``_Goal``/``_Result``/``_Feedback`` messages."""

    name: str
    goal: MsgType
    result: MsgType
    feedback: MsgType


class UnknownType(LookupError):
    """Raised for a type name the registry does not know."""


def schema_dirs() -> list[Path]:
    """The repo's ``schemas/`` when running from a checkout, else the copy shipped in the wheel."""
    repo = Path(__file__).resolve().parents[2] / "schemas"
    if repo.is_dir():
        return [repo]
    installed = Path(__file__).resolve().parents[1] / "_schemas"
    return [installed] if installed.is_dir() else []


def _canonical(name: str, kind: str) -> str | None:
    parts = name.lstrip("/").split("/")
    if len(parts) == 2 and all(parts):
        return f"{parts[0]}/{kind}/{parts[1]}"
    if len(parts) == 3 and all(parts):
        return "/".join(parts)
    return None


def _action_part(canonical: str | None, name: str, known) -> str | None:
    """``pkg/X_FeedbackMessage`` (rosapi's short spelling of an action's part) names
    ``pkg/action/X_FeedbackMessage`` when no ``pkg/msg`` or ``pkg/srv`` type has that name."""
    if canonical is None or canonical in known or len(name.lstrip("/").split("/")) != 2:
        return canonical
    pkg, _kind, base = canonical.split("/")
    part = f"{pkg}/action/{base}"
    return part if part in known else canonical


def _parse(text: str, pkg: str, name: str) -> tuple[Any, Any]:
    """Parse one definition; relative type names resolve against ``pkg/msg``."""
    return get_types_from_msg(text, f"{pkg}/msg/{name}")[f"{pkg}/msg/{name}"]


def _split(path: Path, parts: int) -> list[str]:
    chunks = _SEPARATOR.split(path.read_text(encoding="utf-8"))
    if len(chunks) != parts:
        raise ValueError(
            f"{path}: expected {parts - 1} '---' separator(s), found {len(chunks) - 1}"
        )
    return chunks


def _load_package(pkg_dir: Path, typs: _Typesdict, srvs: set[str], actions: set[str]) -> None:
    pkg = pkg_dir.name
    for path in sorted(pkg_dir.glob("msg/*.msg")):
        typs[f"{pkg}/msg/{path.stem}"] = _parse(path.read_text(encoding="utf-8"), pkg, path.stem)
    for path in sorted(pkg_dir.glob("srv/*.srv")):
        request, response = _split(path, 2)
        typs[f"{pkg}/srv/{path.stem}_Request"] = _parse(request, pkg, f"{path.stem}_Request")
        typs[f"{pkg}/srv/{path.stem}_Response"] = _parse(response, pkg, f"{path.stem}_Response")
        srvs.add(f"{pkg}/srv/{path.stem}")
    for path in sorted(pkg_dir.glob("action/*.action")):
        name = path.stem
        for part, text in zip(("Goal", "Result", "Feedback"), _split(path, 3), strict=True):
            typs[f"{pkg}/msg/{name}{part}"] = typs[f"{pkg}/action/{name}_{part}"] = _parse(
                text, pkg, f"{name}{part}"
            )
        # The wrappers ROS 1 genaction generates, so actionlib clients find e.g. XActionGoal.
        wrappers = {
            "ActionGoal": f"Header header\nactionlib_msgs/GoalID goal_id\n{name}Goal goal",
            "ActionResult": f"Header header\nactionlib_msgs/GoalStatus status\n{name}Result result",
            "ActionFeedback": (
                f"Header header\nactionlib_msgs/GoalStatus status\n{name}Feedback feedback"
            ),
            "Action": (
                f"{name}ActionGoal action_goal\n{name}ActionResult action_result\n"
                f"{name}ActionFeedback action_feedback"
            ),
        }
        for suffix, text in wrappers.items():
            typs[f"{pkg}/msg/{name}{suffix}"] = _parse(text, pkg, f"{name}{suffix}")
        actions.add(f"{pkg}/action/{name}")


def _store_actions(store: Typestore, typs: _Typesdict, actions: set[str]) -> None:
    """Expose actionlib actions already in the store (``pkg/msg/XAction``) as action types."""
    for name, (_, fields) in store.fielddefs.items():
        if not name.endswith("Action") or "/msg/" not in name:
            continue
        if [f[0] for f in fields] != ["action_goal", "action_result", "action_feedback"]:
            continue
        pkg, _, base = name.partition("/msg/")
        base = base[: -len("Action")]
        parts = {
            p: store.fielddefs.get(f"{pkg}/msg/{base}{p}") for p in ("Goal", "Result", "Feedback")
        }
        if all(parts.values()):
            for part, fielddef in parts.items():
                typs.setdefault(f"{pkg}/action/{base}_{part}", fielddef)
            actions.add(f"{pkg}/action/{base}")


def _ros2_action_interfaces(typs: _Typesdict, srvs: set[str], actions: set[str]) -> None:
    """The types of every action's hidden ROS 2 services and feedback topic.

    ROS 2 serves an action as ``_action/send_goal`` (``X_SendGoal``), ``_action/get_result``
    (``X_GetResult``) and the ``_action/feedback`` topic (``X_FeedbackMessage``).
    """
    for action in actions:
        pkg, _, name = action.partition("/action/")
        uuid = "unique_identifier_msgs/UUID goal_id"
        parts = {
            "SendGoal_Request": f"{uuid}\n{pkg}/{name}Goal goal",
            "SendGoal_Response": "bool accepted\ntime stamp",
            "GetResult_Request": uuid,
            "GetResult_Response": f"int8 status\n{pkg}/{name}Result result",
            "FeedbackMessage": f"{uuid}\n{pkg}/{name}Feedback feedback",
        }
        for suffix, text in parts.items():
            typs[f"{action}_{suffix}"] = _parse(text, pkg, f"{name}_{suffix}")
        srvs.update((f"{action}_SendGoal", f"{action}_GetResult"))


def _check_references(store: Typestore) -> None:
    """Fail at load time, not at first use, when a definition names a type nobody defines."""
    for name, (_, fields) in store.fielddefs.items():
        for fname, desc in fields:
            node = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
            if node[0] == Nodetype.NAME and node[1] not in store.fielddefs:
                raise ValueError(f"type {name} field '{fname}' refers to unknown type {node[1]}")


def _field(name: str, desc: tuple[Any, Any]) -> Field:
    array: int | None = None
    if desc[0] == Nodetype.ARRAY:
        desc, array = desc[1]
    elif desc[0] == Nodetype.SEQUENCE:
        desc, array = desc[1][0], 0
    if desc[0] == Nodetype.BASE:
        return Field(name, desc[1][0], False, array)
    typ = _TIME_TYPES.get(desc[1])
    if typ is not None:
        return Field(name, typ, False, array)
    return Field(name, desc[1], True, array)


def replace_definitions(store: Typestore, definitions: _Typesdict) -> None:
    """Register ``definitions`` in ``store`` in place of what it has of those names."""
    for name in definitions:
        store.fielddefs.pop(name, None)
        store.types.pop(name, None)
    store.cache.clear()
    store.register(definitions)


class TypeRegistry:
    """All known interface types; lookups are memoised because they sit on hot paths."""

    def __init__(self, extra_dirs: Iterable[Path | str] = ()) -> None:
        """Load rosbags' ROS 1 Noetic types, then ``schema_dirs()`` and ``extra_dirs``."""
        self.typestore: Typestore = get_typestore(Stores.ROS1_NOETIC)
        typs: _Typesdict = {}
        srvs: set[str] = set()
        actions: set[str] = set()
        for root in [*schema_dirs(), *map(Path, extra_dirs)]:
            for pkg_dir in sorted(p for p in root.iterdir() if p.is_dir()):
                _load_package(pkg_dir, typs, srvs, actions)
        _store_actions(self.typestore, typs, actions)
        _ros2_action_interfaces(typs, srvs, actions)
        if typs:
            self.typestore.register(typs)
        _check_references(self.typestore)
        self._srv_names = srvs
        self._action_names = actions
        self._msgs: dict[str, MsgType] = {}
        self._srvs: dict[str, SrvType] = {}
        self._actions: dict[str, ActionType] = {}
        self._definitions: dict[str, str] = {}
        self.plans: defaultdict[str, dict[str, Any]] = defaultdict(dict)
        """Per-registry memo for the per-type plans codecs compile once: ``plans[kind][type
        name]`` (a plain mapping, read on every message without a call)."""
        self.adopted: dict[str, Any] = {}
        """ROS 2 definitions taken from a replayed recording in place of ours (its codecs follow
        them too): :meth:`adopt`."""

    def adopt(self, definitions: dict[str, tuple[Any, Any]]) -> None:
        """Serve these ROS 2 definitions (a replayed file's own) in place of ours; only for a
        registry of its own (``TypeRegistry()``, never :meth:`default`), before it is used."""
        replace_definitions(self.typestore, definitions)
        self.adopted.update(definitions)
        self._msgs.clear()
        self._definitions.clear()
        self.plans.clear()

    @classmethod
    def default(cls) -> TypeRegistry:
        """The shared registry of built-in types (built once per process)."""
        return _default_registry()

    def msg(self, name: str) -> MsgType:
        """Look up a message type by ``pkg/Type``, ``pkg/msg/Type`` or ``/pkg/Type``."""
        found = self._msgs.get(name)
        if found is not None:
            return found
        canonical = _canonical(name, "msg")
        canonical = TYPE_ALIASES.get(canonical, canonical)  # type: ignore[arg-type]
        canonical = _action_part(canonical, name, self.typestore.fielddefs)
        if (
            canonical is None
            or canonical in _TIME_TYPES
            or canonical not in self.typestore.fielddefs
        ):
            raise UnknownType(f"unknown message type '{name}'")
        found = self._msgs.get(canonical)
        if found is None:
            consts, fields = self.typestore.fielddefs[canonical]
            field_objs = tuple(
                _field(fname, desc) for fname, desc in fields if fname != _PLACEHOLDER
            )
            found = MsgType(
                name=canonical,
                fields=field_objs,
                constants=tuple((c[0], c[1], c[2]) for c in consts),
                has_header=any(f.name == "header" and f.type == HEADER for f in field_objs),
            )
            self._msgs[canonical] = found
        self._msgs[name] = found
        return found

    def srv(self, name: str) -> SrvType:
        """Look up a service type by ``pkg/Type`` or ``pkg/srv/Type``."""
        found = self._srvs.get(name)
        if found is not None:
            return found
        canonical = _action_part(_canonical(name, "srv"), name, self._srv_names)
        if canonical not in self._srv_names:
            raise UnknownType(f"unknown service type '{name}'")
        found = self._srvs.get(canonical) or SrvType(
            canonical, self.msg(f"{canonical}_Request"), self.msg(f"{canonical}_Response")
        )
        self._srvs[canonical] = self._srvs[name] = found
        return found

    def action(self, name: str) -> ActionType:
        """Look up an action by ``pkg/Type``, ``pkg/action/Type`` or ROS 1 ``pkg/TypeAction``."""
        found = self._actions.get(name)
        if found is not None:
            return found
        canonical = _canonical(name, "action")
        if canonical not in self._action_names and canonical and canonical.endswith("Action"):
            canonical = canonical[: -len("Action")]
        if canonical not in self._action_names:
            raise UnknownType(f"unknown action type '{name}'")
        found = self._actions.get(canonical) or ActionType(
            canonical,
            self.msg(f"{canonical}_Goal"),
            self.msg(f"{canonical}_Result"),
            self.msg(f"{canonical}_Feedback"),
        )
        self._actions[canonical] = self._actions[name] = found
        return found

    def has_msg(self, name: str) -> bool:
        try:
            self.msg(name)
        except UnknownType:
            return False
        return True

    def has_srv(self, name: str) -> bool:
        try:
            self.srv(name)
        except UnknownType:
            return False
        return True

    def has_action(self, name: str) -> bool:
        try:
            self.action(name)
        except UnknownType:
            return False
        return True

    @staticmethod
    def short(name: str) -> str:
        """ROS 1 spelling: ``pkg/msg/T`` → ``pkg/T``, ``pkg/srv/T_Request`` → ``pkg/TRequest``."""
        parts = name.lstrip("/").split("/")
        if len(parts) != 3:
            return name
        pkg, kind, base = parts
        for suffix in _PART_SUFFIXES.get(kind, ()):
            if base.endswith(suffix):
                return f"{pkg}/{base[: -len(suffix)]}{suffix[1:]}"
        return f"{pkg}/{base}"

    def msg_names(self) -> list[str]:
        """Canonical names of all message types (not service or action parts)."""
        return sorted(n for n in self.typestore.fielddefs if "/msg/" in n and n not in _TIME_TYPES)

    def srv_names(self) -> list[str]:
        return sorted(self._srv_names)

    def action_names(self) -> list[str]:
        return sorted(self._action_names)

    def definition_text(self, name: str) -> str:
        """Full ROS 1 definition with ``MSG:`` blocks for dependencies (``gendeps --cat``)."""
        canonical = self.msg(name).name
        text = self._definitions.get(canonical)
        if text is None:
            text = self.typestore.generate_msgdef(canonical, ros_version=1)[0]
            self._definitions[canonical] = text
        return text


@cache
def _default_registry() -> TypeRegistry:
    return TypeRegistry()

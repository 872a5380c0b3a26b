"""rmw_zenoh's naming on Zenoh, as plain strings and bytes (no Zenoh import, tested directly).

* data key: ``<domain>/<name without its leading slash>/<dds type>/<RIHS01 hash>``
* liveliness token: ``@ros2_lv/<domain>/<zid>/<nid>/<eid>/<kind>/<enclave>/<namespace>/<node>``
  and, for publishers (MP), subscriptions (MS), service servers (SS) and clients (SC),
  ``/<topic with / as %>/<dds type>/<hash>/<qos>``; an empty chunk is written ``%``.
* sample attachment: int64 sequence number, int64 source timestamp (ns), then the 16-byte
  gid prefixed by its length as one LEB128 byte, all little-endian.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass

from ..cdr import dds_type_name, ros_type_name

ADMIN_SPACE = "@ros2_lv"
NODE, PUBLISHER, SUBSCRIBER, SERVICE, CLIENT = "NN", "MP", "MS", "SS", "SC"
EMPTY = "%"
DURABILITY_TRANSIENT_LOCAL = "1"  # rmw_qos_durability_policy_e
_ATTACHMENT = struct.Struct("<qqB")
GID_SIZE = 16


def data_key(domain: int, name: str, type_name: str, type_hash: str) -> str:
    """The key a topic's samples (or a service's queries) travel on."""
    return f"{domain}/{name.strip('/')}/{dds_type_name(type_name)}/{type_hash}"


def mangle(name: str) -> str:
    """A graph name as one liveliness chunk: every ``/`` becomes ``%``; empty becomes ``%``."""
    return name.replace("/", "%") if name else EMPTY


def unmangle(chunk: str) -> str:
    return "" if chunk == EMPTY else chunk.replace("%", "/")


def qos_key(latched: bool = False, depth: int = 10) -> str:
    """rmw_zenoh's QoS chunk; components equal to its defaults (reliable, volatile, keep
    last) are left empty, so only durability and depth are written."""
    durability = DURABILITY_TRANSIENT_LOCAL if latched else ""
    return f":{durability}:,{depth}:,:,:,,"


def qos_latched(qos: str) -> bool:
    parts = qos.split(":")
    return len(parts) > 1 and parts[1] == DURABILITY_TRANSIENT_LOCAL


def split_node(node: str) -> tuple[str, str]:
    """``/ns/name`` → (``/ns``, ``name``); ``/name`` → ("", ``name``)."""
    ns, _, base = node.rpartition("/")
    return ns, base or EMPTY


@dataclass(frozen=True, slots=True)
class Entity:
    """One graph entity announced by a liveliness token."""

    zid: str
    kind: str
    node: str  # full node name, e.g. /rosapi
    name: str = ""  # topic or service name, absolute
    type_name: str = ""  # ROS 2 spelling pkg/msg/Type ("" when not of the dds form)
    type_hash: str = ""
    qos: str = ""

    @property
    def latched(self) -> bool:
        return qos_latched(self.qos)


def token(
    domain: int,
    zid: str,
    nid: int,
    eid: int,
    kind: str,
    node: str,
    name: str = "",
    type_name: str = "",
    type_hash: str = "",
    qos: str = "",
) -> str:
    """A liveliness token key for a node (``NN``) or one of its endpoints."""
    ns, base = split_node(node)
    key = f"{ADMIN_SPACE}/{domain}/{zid}/{nid}/{eid}/{kind}/{EMPTY}/{mangle(ns)}/{base}"
    if kind == NODE:
        return key
    return f"{key}/{mangle(name)}/{dds_type_name(type_name)}/{type_hash}/{qos}"


def parse_token(key: str) -> Entity | None:
    """The entity a token announces; None for a key that is not a well-formed token."""
    parts = key.split("/")
    if len(parts) < 9 or parts[0] != ADMIN_SPACE:
        return None
    zid, kind, ns, base = parts[2], parts[5], unmangle(parts[7]), parts[8]
    node = f"{ns}/{'' if base == EMPTY else base}"
    if kind == NODE:
        return Entity(zid, kind, node) if len(parts) == 9 else None
    if kind not in (PUBLISHER, SUBSCRIBER, SERVICE, CLIENT) or len(parts) != 13:
        return None
    name = unmangle(parts[9])
    if not name.startswith("/"):
        name = "/" + name
    return Entity(zid, kind, node, name, ros_type_name(parts[10]) or "", parts[11], parts[12])


def pack_attachment(seq: int, stamp_ns: int, gid: bytes) -> bytes:
    if len(gid) != GID_SIZE:
        raise ValueError(f"a gid has {GID_SIZE} bytes, not {len(gid)}")
    return _ATTACHMENT.pack(seq, stamp_ns, GID_SIZE) + gid


def unpack_attachment(data: bytes) -> tuple[int, int, bytes]:
    """(sequence number, source timestamp ns, gid); ValueError for malformed bytes."""
    if len(data) != _ATTACHMENT.size + GID_SIZE:
        raise ValueError(f"attachment of {len(data)} bytes, expected {_ATTACHMENT.size + GID_SIZE}")
    seq, stamp, size = _ATTACHMENT.unpack_from(data)
    if size != GID_SIZE:
        raise ValueError(f"attachment gid length {size}, expected {GID_SIZE}")
    return seq, stamp, bytes(data[_ATTACHMENT.size :])


def endpoints(value: str | Iterable[str] | None) -> list[str]:
    """A comma-separated flag value or a TOML list → endpoint strings."""
    if not value:
        return []
    if isinstance(value, str):
        value = value.split(",")
    return [v.strip() for v in value if v and v.strip()]

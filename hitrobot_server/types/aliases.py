"""The seed's spellings of the robot interfaces, accepted next to the SDK's: the one table.

The Slamware ROS SDK document our clients are written from (the seed) names a few things
differently from the SDK's own ``msg``/``srv`` files, which are what ``schemas/`` holds. A
client written from either must work, so every difference found in the seed is listed here and
nowhere else; the codec (:mod:`.convert`) and the type registry (:mod:`.registry`) consult it.
Everything we send uses the SDK's spelling (the seed's would be ambiguous for ``raw_stcm``).

=============================================  ==========================  ===================
where                                          seed                        SDK (schemas/)
=============================================  ==========================  ===================
``RotateRequest`` (topic ``rotate``)           ``orientation``             ``rotation``
``AddLinesRequest`` (topic ``add_lines``)      ``line`` (an array)         ``lines``
``MoveLinesRequest`` (topic ``move_lines``)    ``line`` (an array)         ``lines``
``SyncSetStcm`` request ``raw_stcm``           ``int8[]`` (-128..127)      ``uint8[]``
message type of ``basic_sensors_values``       ``BasicSensorValuedataArray``  ``...DataArray``
=============================================  ==========================  ===================

A message carrying both spellings of one field is refused (which one was meant is unknown).
"""

from __future__ import annotations

PKG = "slamware_ros_sdk"

TYPE_ALIASES: dict[str, str] = {
    f"{PKG}/msg/BasicSensorValuedataArray": f"{PKG}/msg/BasicSensorValueDataArray",
}
"""Seed type name → the SDK's (canonical ``pkg/msg/Type`` names)."""

FIELD_ALIASES: dict[str, dict[str, str]] = {
    f"{PKG}/msg/RotateRequest": {"orientation": "rotation"},
    f"{PKG}/msg/AddLinesRequest": {"line": "lines"},
    f"{PKG}/msg/MoveLinesRequest": {"line": "lines"},
}
"""Per message type: seed field name → the SDK's."""

SIGNED_BYTES: frozenset[tuple[str, str]] = frozenset({
    (f"{PKG}/srv/SyncSetStcm_Request", "raw_stcm"),
})
"""``uint8[]`` fields that also take the seed's ``int8[]`` numbers (-128..127, two's
complement: -1 is the byte 255)."""

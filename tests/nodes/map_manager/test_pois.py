"""The POI registry (pure)."""

from __future__ import annotations

import math

import pytest

from hitrobot_server.nodes.map_manager.pois import POI_TYPES, PoiError, PoiRegistry


def poi(name: str, kind: int = 100, x: float = 1.0, remarks: str = "") -> dict:
    return {"type": kind, "name": name, "remarks": remarks,
            "pose": {"position": {"x": x, "y": 2.0, "z": 0.0},
                     "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}


def test_add_modify_delete_keep_order():
    reg = PoiRegistry()
    reg.add(poi("a"))
    reg.add(poi("b", 200))
    reg.add(poi("c", 300))
    reg.modify("b", poi("B", 400, x=5.0, remarks="moved"))
    assert [p["name"] for p in reg.all()] == ["a", "B", "c"]
    assert reg.get("B")["pose"]["position"]["x"] == 5.0 and reg.get("b") is None
    reg.modify("a", poi("a", 600))  # same name, new content
    assert reg.get("a")["type"] == 600
    reg.delete("c")
    assert [p["name"] for p in reg.all()] == ["a", "B"] and "c" not in reg


def test_refusals_change_nothing():
    reg = PoiRegistry()
    reg.add(poi("a"))
    reg.add(poi("b"))
    snapshot, revision = reg.all(), reg.revision
    for call, needle in [
        (lambda: reg.add(poi("a")), "already exists"),
        (lambda: reg.modify("zzz", poi("z")), "no POI named 'zzz'"),
        (lambda: reg.modify("a", poi("b")), "already exists"),
        (lambda: reg.delete("zzz"), "no POI named"),
        (lambda: reg.add(poi("")), "empty"),
        (lambda: reg.add(poi("t", 500)), "type"),
        (lambda: reg.add(poi("t", True)), "type"),
        (lambda: reg.add(poi("t", x=math.inf)), "finite"),
        (lambda: reg.add({"name": "x"}), "not a PointOfInterest"),
        (lambda: reg.replace_all([poi("x"), poi("x")]), "twice"),
        (lambda: reg.replace_all([poi("x"), poi("y", 5)]), "type"),
    ]:
        with pytest.raises(PoiError, match=needle):
            call()
        assert reg.all() == snapshot and reg.revision == revision


def test_every_message_constant_is_a_valid_type():
    reg = PoiRegistry()
    for i, kind in enumerate(POI_TYPES):
        reg.add(poi(f"p{i}", kind))
    assert len(reg) == len(POI_TYPES) == 9


def test_returned_pois_are_copies():
    reg = PoiRegistry()
    reg.add(poi("a"))
    reg.all()[0]["name"] = "hacked"
    reg.get("a")["pose"]["position"]["x"] = 99.0
    assert reg.get("a")["pose"]["position"]["x"] == 1.0 and "a" in reg

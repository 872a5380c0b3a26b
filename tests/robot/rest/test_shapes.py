"""REST JSON shapes, including the quirks real robots and gateways show (slamware facts §2, §4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitrobot_server.robot.model import (
    ActionDirection,
    ActionResult,
    ActionStatus,
    DockingStatus,
    HealthComponent,
    HealthLevel,
    LaserScan,
    LocalizationMovement,
    MoveOptionFlag,
    MoveOptions,
    NavigationMode,
    Point2D,
    Pose2D,
    PowerStage,
    Rect,
    SleepMode,
)
from hitrobot_server.robot.rest import shapes
from hitrobot_server.robot.rest.shapes import ShapeError

# --- poses and geometry ----------------------------------------------------------------------


def test_pose3d_round_trip_and_tolerated_spellings():
    p = Pose2D(1.5, -2.0, 0.75)
    assert shapes.pose_from(shapes.pose3d_json(p)) == p
    assert shapes.pose3d_json(p)["z"] == 0.0 and shapes.pose3d_json(p)["pitch"] == 0.0
    # the wrapper docs spell pitch "picth"; a flat Pose2D (POIs) has no z; both read fine
    assert shapes.pose_from({"x": 1, "y": 2, "z": 0, "yaw": 0.5, "picth": 0, "roll": 0}) == \
        Pose2D(1.0, 2.0, 0.5)
    assert shapes.pose_from({"x": 1, "y": 2, "yaw": 0.5}) == Pose2D(1.0, 2.0, 0.5)
    assert shapes.pose_from({"x": 1, "y": 2}).yaw == 0.0


@pytest.mark.parametrize("bad", [{"x": 1}, {"x": "1", "y": 2}, {"x": True, "y": 2}, [1, 2],
                                 {"x": 1, "y": 2, "yaw": None}])
def test_malformed_poses_are_refused(bad):
    with pytest.raises(ShapeError):
        shapes.pose_from(bad)


def test_rectangle_and_path_points():
    r = Rect(-1.0, 2.0, 3.5, 4.0)
    assert shapes.rect_json(r) == {"x": -1.0, "y": 2.0, "width": 3.5, "height": 4.0}
    assert shapes.rect_from(shapes.rect_json(r)) == r
    pts = [Point2D(0.0, 0.0), Point2D(1.0, 0.5)]
    assert shapes.path_json(pts) == {"path_points": [[0.0, 0.0], [1.0, 0.5]]}
    assert shapes.path_from({"path_points": [[0, 0], [1, 0.5]]}) == pts
    assert shapes.path_from({"path_points": [{"x": 0, "y": 0}, {"x": 1, "y": 0.5}]}) == pts
    assert shapes.path_from({}) == []


# --- laser -----------------------------------------------------------------------------------


def test_laser_points_use_the_scan_pose_and_invalid_points_become_inf():
    raw = {"pose": {"x": 1.0, "y": 2.0, "z": 0.0, "yaw": 0.3, "pitch": 0.0, "roll": 0.0},
           "laser_points": [
               {"distance": 2.5, "angle": 0.1, "valid": True},
               {"distance": 3.0, "angle": 0.2, "valid": False},
               {"distance": 1.0, "angle": 0.3, "valid": 1},   # 0/1 from some gateways
               {"distance": 1.0, "angle": 0.4, "valid": 0},
               {"distance": 0.0, "angle": 0.5, "valid": True},  # no return
               {"distance": 4.0, "angle": 0.6},  # valid omitted
           ]}
    scan = shapes.laser_scan_from(raw, stamp=12.5)
    assert scan.pose == Pose2D(1.0, 2.0, 0.3) and scan.stamp == 12.5
    assert scan.angles.tolist() == [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    assert scan.ranges.tolist() == [2.5, math.inf, 1.0, math.inf, math.inf, 4.0]


def test_descending_laser_points_keep_their_order():
    raw = {"pose": {"x": 0, "y": 0, "yaw": 0},
           "laser_points": [{"distance": 1.0 + i, "angle": 3.0 - i, "valid": True}
                            for i in range(4)]}
    scan = shapes.laser_scan_from(raw, 0.0)
    assert scan.angles.tolist() == [3.0, 2.0, 1.0, 0.0]
    assert scan.ranges.tolist() == [1.0, 2.0, 3.0, 4.0]


def test_laser_scan_json_round_trip():
    scan = LaserScan(Pose2D(1.0, 2.0, 0.5), np.array([-1.0, 0.0, 1.0]),
                     np.array([1.5, np.inf, 2.0]), 3.0)
    raw = shapes.laser_scan_json(scan)
    assert raw["laser_points"][1] == {"distance": 0.0, "angle": 0.0, "valid": False}
    back = shapes.laser_scan_from(raw, 3.0)
    assert back.pose == scan.pose and back.ranges.tolist() == [1.5, math.inf, 2.0]


# --- system ----------------------------------------------------------------------------------


def test_power_status_with_the_vendor_spelling_and_unknown_strings():
    raw = {"batteryPercentage": 90, "dockingStatus": "on_dock", "isCharging": True,
           "isDCConnected": False, "powerStage": "shutingdown", "sleepMode": "awake"}
    p = shapes.power_from(raw)
    assert (p.battery_percentage, p.is_charging, p.is_dc_in) == (90, True, False)
    assert p.docking_status is DockingStatus.ON_DOCK
    assert p.power_stage is PowerStage.SHUTTING_DOWN and p.sleep_mode is SleepMode.AWAKE
    assert shapes.power_json(p) == raw
    odd = shapes.power_from({"batteryPercentage": 50, "dockingStatus": "docking",
                             "powerStage": "booting", "sleepMode": "dozing"})
    assert odd.docking_status is DockingStatus.UNKNOWN
    assert odd.power_stage is PowerStage.UNKNOWN and odd.sleep_mode is SleepMode.UNKNOWN


def test_device_info_reads_device_id_with_a_capital_id():
    raw = {"manufacturerId": 255, "manufacturerName": "Slamtec", "modelId": 43792,
           "modelName": "Apollo", "deviceID": "D2E6" + "0" * 28, "hardwareVersion": "511",
           "softwareVersion": "3.6.1-rtm+20210807"}
    info = shapes.device_info_from(raw, "client 1")
    assert info.device_id.startswith("D2E6") and info.model_id == 43792
    assert info.sdp_version == "3.6.1-rtm+20210807" and info.sdk_version == "client 1"
    assert shapes.device_info_json(info) == raw


def test_health_camel_case_snake_case_and_unknown_codes():
    raw = {"hasWarning": True, "hasError": True, "hasFatal": False,
           "hasSystemEmergencyStop": False,  # extra fields on real firmware: ignored
           "baseError": [
               {"id": 1, "component": 2, "errorCode": 0x01020100, "level": 1,
                "message": "power low", "componentErrorCode": 256},
               {"id": 2, "component": 255, "errorCode": 0x02010700, "level": 255,
                "message": "brake released"},
           ]}
    h = shapes.health_from(raw)
    assert h.has_warning and h.has_error and not h.has_fatal
    assert h.errors[0].component is HealthComponent.POWER and h.errors[0].level is HealthLevel.WARN
    # component/level "unknown" (255): taken from the errorCode bits
    assert h.errors[1].component is HealthComponent.SYSTEM
    assert h.errors[1].level is HealthLevel.ERROR and h.errors[1].error_code == 0x02010700
    snake = shapes.health_from({"has_error": True, "base_error": [
        {"id": 3, "component": 3, "error_code": 0x02030400, "level": 2, "message": "watchdog"}]})
    assert snake.has_error and snake.errors[0].error_code == 0x02030400
    # flags missing: derived from the levels
    derived = shapes.health_from({"baseError": [
        {"id": 4, "component": 4, "errorCode": 0x0404060A, "level": 4, "message": "mag"}]})
    assert derived.has_fatal and not derived.has_warning
    assert shapes.health_from(shapes.health_json(h)) == h


def test_capabilities_ready_only_when_the_core_agent_is_enabled():
    assert shapes.core_ready([{"name": "slamware.agent.core", "version": "1", "enabled": True}])
    assert not shapes.core_ready([{"name": "slamware.agent.core", "enabled": False},
                                  {"name": "slamware.agent.platform", "enabled": True}])
    assert shapes.core_ready([])


# --- actions ---------------------------------------------------------------------------------


def test_action_status_codes_follow_the_spec_and_tolerate_paused_2():
    def info(status: int, result: int = 0) -> dict:
        return {"action_id": 7, "action_name": "slamtec.agent.actions.MoveToAction",
                "stage": "GOING_TO_TARGET", "state": {"status": status, "result": result,
                                                      "reason": ""}}

    assert shapes.action_from(info(0)).status is ActionStatus.NEW_BORN
    assert shapes.action_from(info(1)).status is ActionStatus.WORKING
    assert shapes.action_from(info(3)).status is ActionStatus.PAUSED
    assert shapes.action_from(info(2)).status is ActionStatus.PAUSED  # EMU / other firmware
    assert shapes.action_from(info(4)).done
    unknown = shapes.action_from(info(9))
    assert unknown.status is ActionStatus.WORKING and not unknown.done  # never "finished"
    assert shapes.action_from(info(4, -1)).result is ActionResult.FAILED
    assert shapes.action_from(info(4, -2)).result is ActionResult.ABORTED
    assert shapes.action_from(info(4, 5)).result is ActionResult.FAILED
    assert shapes.action_from(info(1)).stage == "GOING_TO_TARGET"  # free text, passed through


def test_an_action_gravestone_has_no_name_or_stage():
    a = shapes.action_from({"action_id": 3, "state": {"status": 4, "result": -1,
                                                       "reason": "no path"}})
    assert (a.action_id, a.action_name, a.stage, a.reason) == (3, "", "", "no path")
    assert a.done and not a.succeeded
    assert shapes.action_from({"action_id": 3, "state": {"status": 4, "result": 0}}).reason == ""


def test_action_info_round_trip():
    a = shapes.action_from({"action_id": 1, "action_name": "x", "stage": "S",
                            "state": {"status": 1, "result": 0, "reason": ""}})
    assert shapes.action_from(shapes.action_json(a)) == a


@pytest.mark.parametrize("bit,name", [(16, "precise"), (32, "with_yaw"),
                                      (512, "fail_retry_count"),
                                      (1024, "find_path_ignoring_dynamic_obstacles"),
                                      (2048, "with_directed_virtual_track")])
def test_each_flag_bit_maps_to_its_rest_string_and_back(bit, name):
    opts = MoveOptions(flags=MoveOptionFlag(bit))
    raw = shapes.move_options_json(opts, yaw=1.25)
    assert raw["flags"] == [name] and raw["mode"] == 0
    back, _yaw = shapes.move_options_from(raw)
    assert int(back.flags) == bit


def test_move_options_yaw_only_with_with_yaw_and_deprecated_bits_become_modes():
    assert "yaw" not in shapes.move_options_json(MoveOptions(), yaw=1.0)
    with_yaw = shapes.move_options_json(MoveOptions(flags=MoveOptionFlag.WITH_YAW), yaw=1.0)
    assert with_yaw["yaw"] == 1.0
    assert shapes.move_options_from(with_yaw)[1] == 1.0
    strict = shapes.move_options_json(MoveOptions(flags=MoveOptionFlag.KEY_POINTS))
    assert strict == {"mode": 1, "flags": []}
    priority = shapes.move_options_json(MoveOptions(flags=MoveOptionFlag.KEY_POINTS_WITH_OA))
    assert priority["mode"] == 2
    explicit = MoveOptions(flags=MoveOptionFlag.KEY_POINTS,
                           mode=NavigationMode.PRIORITY_VIRTUAL_TRACK)
    assert shapes.move_options_json(explicit)["mode"] == 2  # an explicit mode wins
    # no REST form: not sent (APPENDING is emulated by the client)
    dropped = MoveOptionFlag.MILESTONE | MoveOptionFlag.NO_SMOOTH | MoveOptionFlag.APPENDING \
        | MoveOptionFlag.RETURN_UNREACHABLE_DIRECTLY
    assert shapes.move_options_json(MoveOptions(flags=dropped)) == {"mode": 0, "flags": []}


def test_move_options_extras_round_trip():
    opts = MoveOptions(flags=MoveOptionFlag.PRECISE, speed_ratio=0.5, acceptable_precision=0.2,
                       fail_retry_count=3, mode=NavigationMode.STRICT_VIRTUAL_TRACK)
    raw = shapes.move_options_json(opts)
    assert raw == {"mode": 1, "flags": ["precise", "fail_retry_count"], "speed_ratio": 0.5,
                   "acceptable_precision": 0.2, "fail_retry_count": 3}
    back, _ = shapes.move_options_from(raw)
    assert back == MoveOptions(flags=MoveOptionFlag(16 | 512), speed_ratio=0.5,
                               mode=NavigationMode.STRICT_VIRTUAL_TRACK,
                               acceptable_precision=0.2, fail_retry_count=3)
    with pytest.raises(ShapeError, match="unknown flag"):
        shapes.move_options_from({"mode": 0, "flags": ["no_smooth"]})
    with pytest.raises(ShapeError, match="mode"):
        shapes.move_options_from({"mode": 7, "flags": []})


def test_action_requests_have_the_documented_shapes():
    one = shapes.move_to_request([Point2D(1.0, 2.0)], None, 0.0)
    assert one == {"action_name": "slamtec.agent.actions.MoveToAction",
                   "options": {"target": {"x": 1.0, "y": 2.0, "z": 0.0},
                               "move_options": {"mode": 0, "flags": []}}}
    series = shapes.move_to_request([Point2D(1, 2), Point2D(3, 4)], None, 0.0)
    assert series["action_name"].endswith("SeriesMoveToAction")
    assert len(series["options"]["targets"]) == 2
    by = shapes.move_by_request(ActionDirection.TURNLEFT, None, 0.25)
    assert by["options"] == {"duration": 250, "direction": 3}
    theta = shapes.move_by_request(None, 0.5, 0.5)
    assert theta["options"] == {"duration": 500, "theta": 0.5}
    assert shapes.rotate_request(1.0, True)["action_name"].endswith("RotateToAction")
    assert shapes.rotate_request(1.0, False) == {
        "action_name": "slamtec.agent.actions.RotateAction", "options": {"angle": 1.0}}
    assert shapes.go_home_request() == {"action_name": "slamtec.agent.actions.GoHomeAction",
                                        "options": {}}
    home = shapes.go_home_request(MoveOptions(mode=NavigationMode.STRICT_VIRTUAL_TRACK))
    assert home["options"]["gohome_options"]["flags"] == "dock"
    assert home["options"]["gohome_options"]["move_options"]["mode"] == 1


def test_recover_localization_request():
    whole = shapes.recover_request(None, None, None)
    assert whole == {"action_name": "slamtec.agent.actions.RecoverLocalizationAction",
                     "options": {}}
    assert "area" not in shapes.recover_request(Rect(0, 0, 0, 0), None, None)["options"]
    area = shapes.recover_request(Rect(1, 2, 3, 4), 5000, LocalizationMovement.ROTATE_ONLY)
    assert area["options"] == {"area": {"x": 1.0, "y": 2.0, "width": 3.0, "height": 4.0},
                               "relocalization_options": {
                                   "max_recover_time": 5000,
                                   "recover_movement_type": "RotateOnly"}}
    assert shapes.recover_request(None, None, LocalizationMovement.NO_MOVE)["options"] == {
        "relocalization_options": {"recover_movement_type": "NoMove"}}
    # ANY has no REST form: left to the robot
    assert shapes.recover_request(None, None, LocalizationMovement.ANY)["options"] == {}
    assert shapes.movement_from("RotateOnly") is LocalizationMovement.ROTATE_ONLY
    with pytest.raises(ShapeError):
        shapes.movement_from("Any")


# --- artifacts -------------------------------------------------------------------------------


def test_lines_ignore_metadata_such_as_bezier_control_point_strings():
    raw = [{"id": 199, "start": {"x": 0, "y": 0}, "end": {"x": 1, "y": 1},
            "metadata": {"control_point1": "{'x':0.1,'y':0.1}"}},
           {"id": 200, "start": {"x": 2, "y": 0}, "end": {"x": 3, "y": 1}}]
    lines = shapes.lines_from(raw)
    assert [ln.id for ln in lines] == [199, 200]
    assert lines[0].end == Point2D(1.0, 1.0)
    assert shapes.line_json(lines[1]) == {"id": 200, "start": {"x": 2.0, "y": 0.0},
                                          "end": {"x": 3.0, "y": 1.0}, "metadata": {}}
    with pytest.raises(ShapeError):
        shapes.lines_from({"lines": raw})


def _inside_polygon(x: float, y: float, poly: list[Point2D]) -> bool:
    inside = False
    for a, b in zip(poly, poly[1:] + poly[:1], strict=True):
        if (a.y > y) != (b.y > y):
            t = (y - a.y) / (b.y - a.y)
            if x < a.x + t * (b.x - a.x):
                inside = not inside
    return inside


def _inside_area(x: float, y: float, start: Point2D, end: Point2D, half: float) -> bool:
    dx, dy = end.x - start.x, end.y - start.y
    length = math.hypot(dx, dy)
    if length < 1e-12:
        return abs(x - start.x) <= half + 1e-9 and abs(y - start.y) <= half + 1e-9
    ux, uy = dx / length, dy / length
    along = (x - start.x) * ux + (y - start.y) * uy
    across = -(x - start.x) * uy + (y - start.y) * ux
    return -1e-9 <= along <= length + 1e-9 and abs(across) <= half + 1e-9


def test_a_rotated_rectangle_is_one_exact_area():
    c, s = math.cos(0.4), math.sin(0.4)
    corners = [Point2D(2 + c * x - s * y, 3 + s * x + c * y)
               for x, y in ((0, 0), (2, 0), (2, 1), (0, 1))]
    areas = shapes.cover_polygon(corners)
    assert len(areas) == 1
    start, end, half = areas[0]
    assert abs(half - 1.0) < 1e-9  # across the long side, along the short one
    assert abs(math.dist((start.x, start.y), (end.x, end.y)) - 1.0) < 1e-9
    back = shapes.rectangle_corners(start, end, half)
    assert sorted((round(p.x, 9), round(p.y, 9)) for p in back) == \
        sorted((round(p.x, 9), round(p.y, 9)) for p in corners)


@pytest.mark.parametrize("poly", [
    [(5, 5), (6, 5), (5.5, 6)],                                       # triangle
    [(0, 0), (3, 0), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)],  # U shape
    [(0.013, 0.021), (1.37, 0.29), (0.91, 1.73), (0.33, 0.88)],       # skewed quad
])
def test_any_polygon_is_covered_by_its_areas_and_not_much_more(poly):
    pts = [Point2D(float(x), float(y)) for x, y in poly]
    areas = shapes.cover_polygon(pts, step=0.1)
    rng = np.random.default_rng(1)
    xs = [p.x for p in pts]
    ys = [p.y for p in pts]
    for x, y in zip(rng.uniform(min(xs), max(xs), 4000), rng.uniform(min(ys), max(ys), 4000),
                    strict=True):
        if _inside_polygon(x, y, pts):
            assert any(_inside_area(x, y, *a) for a in areas), (x, y)
    # and nothing much beyond: every area corner is within one strip of the polygon
    for a in areas:
        for corner in shapes.rectangle_corners(*a):
            assert min(xs) - 1e-9 <= corner.x <= max(xs) + 1e-9
            assert min(ys) - 1e-9 <= corner.y <= max(ys) + 1e-9
            near = any(_inside_polygon(corner.x + dx, corner.y + dy, pts)
                       for dx in np.linspace(-0.1, 0.1, 9) for dy in np.linspace(-0.1, 0.1, 9))
            assert near, corner


def test_axis_aligned_shapes_need_few_areas():
    u_shape = [Point2D(x, y) for x, y in
               ((0, 0), (3, 0), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3))]
    assert len(shapes.cover_polygon(u_shape)) == 3


def test_degenerate_polygons_still_give_an_area():
    assert shapes.cover_polygon([]) == []
    (area,) = shapes.cover_polygon([Point2D(1, 1)])
    assert area == (Point2D(1, 1), Point2D(1, 1), 0.025)
    (seg,) = shapes.cover_polygon([Point2D(0, 0), Point2D(1, 0)])
    assert seg == (Point2D(0, 0), Point2D(1, 0), 0.025)
    (flat,) = shapes.cover_polygon([Point2D(0, 2), Point2D(3, 2), Point2D(1, 2)])
    assert flat == (Point2D(0, 2), Point2D(3, 2), 0.025)


def test_owned_areas_are_found_by_their_metadata():
    raw = [{"id": 1, "area": {}, "metadata": dict(shapes.BLOCKED_METADATA)},
           {"id": 2, "area": {}, "metadata": {"display_name": "someone else's"}},
           {"id": 3, "area": {}}]
    assert shapes.owned_area_ids(raw) == [1]

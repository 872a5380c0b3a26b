from hitrobot_server.robot.model import (
    ActionInfo,
    ActionResult,
    ActionStatus,
    HealthComponent,
    HealthError,
    HealthInfo,
    HealthLevel,
    MoveOptionFlag,
    Rect,
    health_error_code,
)


def test_error_codes_match_the_slamware_manual():
    assert health_error_code(HealthLevel.ERROR, HealthComponent.SYSTEM, 0x0700) == 33621760
    assert health_error_code(HealthLevel.WARN, HealthComponent.POWER, 0x0100) == 16908544


def test_health_summary_flags_follow_error_levels():
    warn = HealthError(1, HealthComponent.POWER, HealthLevel.WARN, 16908544, "power low")
    info = HealthInfo.from_errors((warn,))
    assert (info.has_warning, info.has_error, info.has_fatal) == (True, False, False)
    assert not HealthInfo.from_errors(()).has_warning


def test_move_option_flags_keep_sdk_bit_values():
    flags = MoveOptionFlag(16 | 32 | 2)
    assert flags == MoveOptionFlag.PRECISE | MoveOptionFlag.WITH_YAW | MoveOptionFlag.MILESTONE
    assert MoveOptionFlag.KEY_POINTS_WITH_OA == 128


def test_action_info_done_only_at_status_four():
    working = ActionInfo(1, "x", "", ActionStatus.WORKING, ActionResult.SUCCESS, "")
    failed = ActionInfo(1, "x", "", ActionStatus.DONE, ActionResult.FAILED, "why")
    assert not working.done and not working.succeeded
    assert failed.done and not failed.succeeded


def test_empty_rect():
    assert Rect(0, 0, 0, 5).is_empty
    assert not Rect(0, 0, 1, 1).is_empty

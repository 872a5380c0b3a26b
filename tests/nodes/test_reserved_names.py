"""The names a robot may not take, collected from what serves them (the nodes' GLOBAL_NAMES,
the bus's site-wide names, the recorder's and the player's): at least every name the bus
hard-coded before they were collected, so the same robot names are refused."""

from __future__ import annotations

import pytest

from hitrobot_server.bus.namespace import check_robot_name
from hitrobot_server.nodes.assembly import BESIDE_THE_NODES, NODE_CLASSES, reserved_names
from hitrobot_server.record import blackbox_control, control, player, replay_launcher

FROZEN = frozenset({  # bus/namespace.py's RESERVED, as it was hard-coded (issue 32)
    "tf", "tf_static", "rosout", "rosapi", "map", "map_manager", "fleet", "diagnostics_agg",
    "diagnostic_aggregator", "tf2_web_republisher", "republish_tfs", "hitrobot_server",
    "slamware_ros_sdk_server_node", "scan", "odom", "cmd_vel", "move_base", "move_base_simple",
    "robot_pose", "robot_pose_publisher", "initialpose", "navigation", "planning", "graph",
    "cmd_string", "system_shell", "ros_mode", "robot_state", "robot_id", "Odometry",
    "map_files", "locomotion", "stand_up", "sit_down", "set_listen", "set_map",
    "list_map_files", "load_laser_map", "save_graph_file", "load_graph_file",
    "set_initialpose", "cloud_registered", "merged_points", "downsampled_points",
    "pointcloud_accumulator_node", "compute_path_to_pose", "follow_path",
    "intelligent_navigate_to_pose", "intelligent_navigat_to_pose", "intelligent_navigation",
    "nav", "nav2_actions", "conventional", "shell", "patrol",
    "record", "recorder", "replay", "add_two_ints", "fibonacci",
})


def test_the_collected_names_hold_every_name_once_hard_coded():
    assert reserved_names() >= FROZEN, sorted(FROZEN - reserved_names())


def test_every_node_class_declares_absolute_names():
    for cls in NODE_CLASSES:
        assert all(name.startswith("/") for name in cls.GLOBAL_NAMES), cls


def test_the_names_beside_the_nodes_are_still_the_recorders_and_the_players():
    theirs = {name.strip("/").split("/")[0] for name in (
        control.NODE, control.STATE_TOPIC, player.NODE, player.STATE_TOPIC,
        blackbox_control.NODE, replay_launcher.NODE)}
    assert theirs == {name.strip("/") for name in BESIDE_THE_NODES}


@pytest.mark.parametrize("name", sorted(FROZEN))
def test_a_reserved_name_is_refused_with_the_same_text(name):
    with pytest.raises(ValueError, match=f"robot name '{name}' would shadow the global name "
                                         f"'/{name}'"):
        check_robot_name(name, reserved_names())

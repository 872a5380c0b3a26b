"""One clock: every stamp the robot's topics carry comes from the server's wall clock."""

from __future__ import annotations

import time

from tests.helpers import Watcher

TOPICS = {
    "/scan": "sensor_msgs/LaserScan",
    "/slamware_ros_sdk_server_node/scan": "sensor_msgs/LaserScan",
    "/odom": "nav_msgs/Odometry",
    "/slamware_ros_sdk_server_node/odom": "nav_msgs/Odometry",
    "/tf": "tf2_msgs/TFMessage",
    "/cloud_registered": "sensor_msgs/PointCloud2",
    "/merged_points": "sensor_msgs/PointCloud2",
    "/downsampled_points": "sensor_msgs/PointCloud2",
}


def seconds(stamp: dict) -> float:
    return stamp["secs"] + stamp["nsecs"] * 1e-9


async def test_scan_tf_odom_and_clouds_share_one_clock(make_server):
    # a fast simulator: its own clock runs 4x wall time, so a leaked backend stamp shows
    server = await make_server(robot="sim", sim_speed=4.0)
    w = await Watcher.open(server.port)
    try:
        for topic, type_name in TOPICS.items():
            await w.subscribe(topic, type_name)
        await w.until(lambda: all(w.latest(t) for t in TOPICS), 15, "every topic")
        # the laser's transform comes with the scan, the robot's with odometry
        await w.until(lambda: {"laser", "base_link"} <= {
            t["child_frame_id"].lstrip("/") for _, m in w.messages["/tf"] for t in m["transforms"]},
            10, "map→laser and odom→base_link on /tf")
        stamps = {topic: seconds(w.latest(topic)["header"]["stamp"])
                  for topic in TOPICS if topic != "/tf"}
        for _, msg in w.messages["/tf"][-10:]:
            for t in msg["transforms"]:
                stamps[f"/tf {t['child_frame_id']}"] = seconds(t["header"]["stamp"])
        assert max(stamps.values()) - min(stamps.values()) < 1.0, stamps
        assert abs(max(stamps.values()) - time.time()) < 5.0, stamps  # wall time, not uptime
        laser_stamps = {(t["header"]["stamp"]["secs"], t["header"]["stamp"]["nsecs"])
                        for _, m in w.messages["/tf"] for t in m["transforms"]
                        if t["child_frame_id"].lstrip("/") == "laser"}
        scan_stamps = {(m["header"]["stamp"]["secs"], m["header"]["stamp"]["nsecs"])
                       for _, m in w.messages["/scan"]}
        assert laser_stamps & scan_stamps  # a scan and its map→laser transform: one stamp
        topics = (await w.call("/rosapi/topic_type", {"topic": "/scan"}))["values"]
        assert topics["type"] == "sensor_msgs/LaserScan"
    finally:
        await w.close()

"""The Slamware REST endpoints this package speaks (client and sim-device share them).

Operation segments such as ``:current`` and ``:enable`` are literal text, not placeholders.
"""

from __future__ import annotations

from ..model import ArtifactUsage

SYSTEM = "/api/core/system/v1"
SLAM = "/api/core/slam/v1"
MOTION = "/api/core/motion/v1"
ARTIFACT = "/api/core/artifact/v1"

CAPABILITIES = f"{SYSTEM}/capabilities"
POWER_STATUS = f"{SYSTEM}/power/status"
POWER_SHUTDOWN = f"{SYSTEM}/power/:shutdown"
POWER_RESTART_MODULE = f"{SYSTEM}/power/:restartmodule"
ROBOT_INFO = f"{SYSTEM}/robot/info"
ROBOT_HEALTH = f"{SYSTEM}/robot/health"  # DELETE .../{error_code}
LASERSCAN = f"{SYSTEM}/laserscan"

POSE = f"{SLAM}/localization/pose"
ODOPOSE = f"{SLAM}/localization/odopose"
QUALITY = f"{SLAM}/localization/quality"
LOCALIZATION_ENABLE = f"{SLAM}/localization/:enable"
MAPPING_ENABLE = f"{SLAM}/mapping/:enable"
HOMEPOSE = f"{SLAM}/homepose"
KNOWN_AREA = f"{SLAM}/knownarea"
MAPS = f"{SLAM}/maps"
EXPLORE_MAP = f"{SLAM}/maps/explore"
STCM = f"{SLAM}/maps/stcm"

ACTION_FACTORIES = f"{MOTION}/action-factories"
ACTIONS = f"{MOTION}/actions"  # GET .../{action_id}
CURRENT_ACTION = f"{MOTION}/actions/:current"
PATH = f"{MOTION}/path"
MILESTONES = f"{MOTION}/milestones"
SPEED = f"{MOTION}/speed"

LINES = f"{ARTIFACT}/lines"  # .../{usage}, .../{usage}/{id}
RECTANGLE_AREAS = f"{ARTIFACT}/rectangle-areas"  # .../{usage}, .../{usage}/{id}
FORBIDDEN_AREA = "forbidden_area"

LINE_USAGES = {ArtifactUsage.VIRTUAL_WALL: "walls", ArtifactUsage.VIRTUAL_TRACK: "tracks"}
USAGE_OF = {name: usage for usage, name in LINE_USAGES.items()}
RECTANGLE_USAGES = ("forbidden_area", "elevator_area", "dangerous_area", "coverage_area",
                    "maintenance_area", "sensor_disable_area", "restricted_area")


def lines(usage: ArtifactUsage) -> str:
    return f"{LINES}/{LINE_USAGES[ArtifactUsage(usage)]}"

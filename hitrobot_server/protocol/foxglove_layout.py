"""A Foxglove layout for this server's own topics, the file the Foxglove app imports (issue 49
item 8): the map with every robot's scan, plan and odometry in a 3D panel, per robot a Teleop
panel on its ``cmd_vel`` and its battery plotted, the diagnostics, and on a fleet the task
table and a ``/fleet/dispatch`` call.

The JSON is the layout format of the Foxglove SDK (``foxglove.layouts.Layout``: ``version``
1, a tree of split/tab containers and panels, unset fields left out); the tests build the
same layout with the SDK's classes and compare. Pure: robot names in, a dict out.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

MAP_FRAME = "map"
SCAN = "/scan"
PLAN = "/slamware_ros_sdk_server_node/global_plan_path"
ODOM = "/odom"
CMD_VEL = "/cmd_vel"
BATTERY = "/slamware_ros_sdk_server_node/robot_basic_state.battery_percentage"
DIAGNOSTICS = "/diagnostics_agg"
TASKS = "/fleet/tasks.tasks"
DISPATCH = "/fleet/dispatch"
DISPATCH_EXAMPLE = '{\n  "poi": "",\n  "robot": ""\n}'  # a POI by name, any robot


def panel(panel_type: str, config: dict[str, Any], title: str | None = None) -> dict[str, Any]:
    """One panel as the SDK writes it (``version`` 1; no title: the panel's own)."""
    out: dict[str, Any] = {"type": "panel", "panelType": panel_type, "config": config}
    if title is not None:
        out["title"] = title
    out["version"] = 1
    return out


def split(direction: str, *items: tuple[float, dict[str, Any]]) -> dict[str, Any]:
    return {"type": "split", "direction": direction,
            "items": [{"proportion": p, "content": c} for p, c in items]}


def tabs(*items: tuple[str, dict[str, Any]]) -> dict[str, Any]:
    return {"type": "tabs", "selectedTabIndex": 0,
            "tabs": [{"title": t, "content": c} for t, c in items]}


def scene(prefixes: Sequence[str]) -> dict[str, Any]:
    """The 3D panel: the map, and for each robot its scan, global plan and odometry."""
    topics: dict[str, Any] = {"/map": {"visible": True, "colorMode": "map"}}
    for p in prefixes:
        topics[p + SCAN] = {"visible": True, "cubeOutline": False, "pointShape": "circle",
                            "pointSize": 3, "colorMode": "flat", "flatColor": "#ff4040"}
        topics[p + PLAN] = {"visible": True, "type": "line", "lineWidth": 0.05}
        topics[p + ODOM] = {"visible": True, "type": "arrow"}
    return panel("ThreeDee", {"topics": topics, "fixedFrame": MAP_FRAME,
                              "followMode": "follow-none"}, "Map")


def robot_controls(prefix: str) -> dict[str, Any]:
    """One robot's Teleop (its ``cmd_vel``) above its battery plot."""
    teleop = panel("Teleop", {"topic": prefix + CMD_VEL, "publishRate": 5})
    battery = panel("Plot", {"paths": [{"label": "battery %", "value": prefix + BATTERY}],
                             "minYValue": 0, "maxYValue": 100}, "Battery")
    return split("column", (1, teleop), (1, battery))


def layout(robots: Sequence[str], fleet: bool) -> dict[str, Any]:
    """The layout for robots named ``robots`` ("" for the single unnamed one; none: a bridge
    only), with the fleet's panels when ``fleet``."""
    prefixes = [f"/{name}" if name else "" for name in robots]
    side: list[tuple[float, dict[str, Any]]] = []
    if prefixes:
        side.append((2, tabs(*((name or "robot", robot_controls(p))
                               for name, p in zip(robots, prefixes, strict=True)))))
    if fleet:
        side.append((2, tabs(
            ("Tasks", panel("Table", {"topicPath": TASKS}, "Fleet tasks")),
            ("Dispatch", panel("ServiceCall", {
                "serviceName": DISPATCH, "requestPayload": DISPATCH_EXAMPLE,
                "buttonText": "Dispatch"}, "Dispatch a task")))))
    side.append((1, panel("DiagnosticsSummary", {"topicToRender": DIAGNOSTICS})))
    return {"version": 1, "content": split("row", (2, scene(prefixes)),
                                            (1, split("column", *side)))}

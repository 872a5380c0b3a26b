"""The Foxglove layout the server offers (issue 49 item 8), checked against the layout format
of the Foxglove SDK's Python package: the same layout built with ``foxglove.layouts``'s
classes serialises to the very JSON we serve. The served file's topics and service are the
server's own: every name in it is one the server has (a fleet: every robot's)."""

from __future__ import annotations

import asyncio
import json
import urllib.request

import foxglove.layouts as fl
import pytest

from hitrobot_server.protocol import foxglove_layout as L
from hitrobot_server.robot.options import RobotEntry
from tests.helpers import WsClient


def sdk_layout(robots: list[str], fleet: bool) -> fl.Layout:
    """What the layout is meant to be, said with the SDK's classes."""
    prefixes = [f"/{n}" if n else "" for n in robots]
    topics: dict = {"/map": fl.BaseRendererRosOccupancyGridTopicSettings(visible=True,
                                                                         color_mode="map")}
    for p in prefixes:
        topics[p + L.SCAN] = fl.BaseRendererLaserScanTopicSettings(
            visible=True, point_size=3, color_mode="flat", flat_color="#ff4040")
        topics[p + L.PLAN] = fl.BaseRendererPosesTopicSettings(visible=True, type="line",
                                                               line_width=0.05)
        topics[p + L.ODOM] = fl.BaseRendererPoseTopicSettings(visible=True, type="arrow")
    scene = fl.ThreeDeePanel(title="Map", config=fl.ThreeDeeConfig(
        topics=topics, fixed_frame="map", follow_mode="follow-none"))
    side = []
    if prefixes:
        side.append(fl.SplitItem(proportion=2, content=fl.TabContainer(tabs=[
            fl.TabItem(title=n or "robot", content=controls(p))
            for n, p in zip(robots, prefixes, strict=True)])))
    if fleet:
        side.append(fl.SplitItem(proportion=2, content=fl.TabContainer(tabs=[
            fl.TabItem(title="Tasks", content=fl.TablePanel(
                title="Fleet tasks", config=fl.TableConfig(topic_path="/fleet/tasks.tasks"))),
            fl.TabItem(title="Dispatch", content=fl.ServiceCallPanel(
                title="Dispatch a task", config=fl.ServiceCallConfig(
                    service_name="/fleet/dispatch", request_payload=L.DISPATCH_EXAMPLE,
                    button_text="Dispatch")))])))
    side.append(fl.SplitItem(proportion=1, content=fl.DiagnosticsSummaryPanel(
        config=fl.DiagnosticsSummaryConfig(topic_to_render="/diagnostics_agg"))))
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=2, content=scene),
        fl.SplitItem(proportion=1, content=fl.SplitContainer(direction="column", items=side))]))


def controls(prefix: str) -> fl.SplitContainer:
    return fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=1, content=fl.TeleopPanel(
            config=fl.TeleopConfig(topic=prefix + "/cmd_vel", publish_rate=5))),
        fl.SplitItem(proportion=1, content=fl.PlotPanel(title="Battery", config=fl.PlotConfig(
            paths=[fl.PlotSeries(label="battery %", value=prefix + L.BATTERY)],
            min_y_value=0, max_y_value=100)))])


@pytest.mark.parametrize(("robots", "fleet"), [([""], False), (["a", "b"], True), ([], False)])
def test_the_layout_is_the_sdks(robots, fleet):
    ours = json.loads(json.dumps(L.layout(robots, fleet), allow_nan=False))
    assert ours == json.loads(sdk_layout(robots, fleet).to_json())


def served(port: int) -> dict:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/foxglove/layout.json",
                                timeout=10) as answer:
        assert answer.headers["Content-Type"] == "application/json"
        return json.loads(answer.read())


def names_in(layout: dict) -> tuple[set[str], set[str]]:
    """The topics and services a layout's panels read, publish or call."""
    topics: set[str] = set()
    services: set[str] = set()

    def walk(node: dict) -> None:
        for child in (node.get("items") or []) + (node.get("tabs") or []):
            walk(child["content"])
        config = node.get("config") or {}
        topics.update(config.get("topics", {}))
        for key in ("topic", "topicToRender", "topicPath"):
            if key in config:
                topics.add(config[key].split(".")[0])
        topics.update(p["value"].split(".")[0] for p in config.get("paths", []))
        if "serviceName" in config:
            services.add(config["serviceName"])

    walk(layout["content"])
    return topics, services


async def the_servers_names(port: int) -> tuple[set[str], set[str]]:
    client = await WsClient.open(port)
    try:
        topics = (await client.call("/rosapi/topics", timeout=20))["values"]["topics"]
        services = (await client.call("/rosapi/services", timeout=20))["values"]["services"]
    finally:
        await client.close()
    return set(topics), set(services)


async def test_a_single_robots_layout_names_its_topics(make_server):
    server = await make_server(robot="sim")
    layout = await asyncio.to_thread(served, server.port)  # (the server runs on this loop)
    assert layout == json.loads(sdk_layout([""], fleet=False).to_json())
    topics, services = names_in(layout)
    has_topics, _ = await the_servers_names(server.port)
    assert topics <= has_topics and not services


async def test_a_fleets_layout_names_every_robots_topics_and_dispatch(make_server):
    server = await make_server(robots=(RobotEntry("a", "sim", (6.0, 8.0, 0.0)),
                                       RobotEntry("b", "sim", (12.0, 8.0, 0.0))))
    layout = await asyncio.to_thread(served, server.port)  # (the server runs on this loop)
    assert layout == json.loads(sdk_layout(["a", "b"], fleet=True).to_json())
    topics, services = names_in(layout)
    has_topics, has_services = await the_servers_names(server.port)
    assert {"/a/cmd_vel", "/b/cmd_vel", "/a/scan", "/b/scan", "/fleet/tasks"} <= topics
    assert topics <= has_topics
    assert services == {"/fleet/dispatch"} <= has_services

"""The server's log says once per robot that it connected, by its name (issue 46, friction 8:
two robots logged "robot connected" twice, without saying which); a black-box file asked for
by hand is news (INFO), an incident's a warning."""

from __future__ import annotations

import logging

from tests.helpers import WsClient
from tests.nodes.fleet.test_node import fleet


async def test_each_robot_is_logged_connected_once_by_its_name(make_server, tmp_path, caplog):
    caplog.set_level(logging.INFO, logger="hitrobot_server")
    _server, w = await fleet(make_server, tmp_path, ("alpha", 4.0, 2.0), ("beta", 12.0, 8.0))
    await w.close()  # both robots idle on /fleet/robots: both connected
    lines = [r.getMessage() for r in caplog.records if r.getMessage().endswith(" connected")]
    assert sorted(lines) == ["robot alpha connected", "robot beta connected"], lines


async def test_a_snapshot_is_logged_at_info_an_incident_at_warning(make_server, tmp_path, caplog):
    caplog.set_level(logging.INFO, logger="hitrobot_server.record")
    server = await make_server(black_box=10.0, record_dir=str(tmp_path / "recordings"))
    client = await WsClient.open(server.port)
    try:
        reply = await client.call("/record/snapshot", {"reason": "asked"}, timeout=60)
        assert reply["values"]["success"], reply
        written = [r for r in caplog.records if "messages written to" in r.getMessage()]
        assert [r.levelno for r in written] == [logging.INFO], [r.getMessage() for r in written]
    finally:
        await client.close()

"""``/fleet/policy``: the charging policy's thresholds and the site's time zone, as a console
reads them, from a real server with a named simulated robot."""

from __future__ import annotations

import datetime as dt

from hitrobot_server.nodes.fleet.policy import ChargePolicy
from hitrobot_server.nodes.fleet.policyinfo import describe
from hitrobot_server.robot.options import RobotEntry
from tests.helpers import Watcher


async def test_the_policy_and_the_site_zone_are_readable(make_server, tmp_path):
    server = await make_server(robots=(RobotEntry("a", "sim", (4.0, 8.0, 0.0)),),
                               map_dir=str(tmp_path), charge_below=30.0, charge_until=80.0,
                               site_timezone="Asia/Kolkata")
    w = await Watcher.open(server.port)
    try:
        reply = await w.call("/fleet/policy", {})
        assert reply["result"], reply
        got = reply["values"]
        assert (got["charge_below"], got["charge_until"]) == (30.0, 80.0)
        assert got["drain"] > 0 and got["reserve"] > 0
        assert (got["timezone"], got["utc_offset"], got["zone_name"]) == (
            "Asia/Kolkata", 5 * 3600 + 1800, "IST")
    finally:
        await w.close()


def test_a_server_without_a_site_zone_reports_its_own_offset():
    zone = dt.timezone(dt.timedelta(hours=-3), "X-3")
    got = describe(ChargePolicy(), zone, 1_800_000_000.0)
    assert (got["timezone"], got["utc_offset"], got["zone_name"]) == ("", -3 * 3600, "X-3")
    assert (got["charge_below"], got["charge_until"]) == (25.0, 90.0)

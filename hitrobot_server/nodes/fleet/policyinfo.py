"""``/fleet/policy`` (``hitrobot_msgs/FleetPolicy``): the charging policy's thresholds and the
site's time zone, read by a console that shows "charges below 25 % until 90 %" and the tasks'
and schedules' times as the site's clock reads them (a browser's own zone may be another)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from zoneinfo import ZoneInfo

from .member import PKG
from .policy import ChargePolicy


class PolicyService:
    def __init__(self, policy: ChargePolicy, zone: dt.tzinfo, clock: Callable[[], float],
                 serve: Callable[..., None]):
        self.policy, self.zone, self.clock = policy, zone, clock
        serve("/fleet/policy", f"{PKG}/FleetPolicy", self._read)

    async def _read(self, _request: dict) -> dict:
        return describe(self.policy, self.zone, self.clock())


def describe(policy: ChargePolicy, zone: dt.tzinfo, now: float) -> dict:
    """The policy and ``zone`` at ``now`` as a ``FleetPolicy`` reply."""
    local = dt.datetime.fromtimestamp(now, zone)
    offset = local.utcoffset() or dt.timedelta(0)
    return {"charge_below": policy.charge_below, "charge_until": policy.charge_until,
            "drain": policy.drain, "reserve": policy.reserve,
            "timezone": zone.key if isinstance(zone, ZoneInfo) else "",
            "utc_offset": int(offset.total_seconds()), "zone_name": local.tzname() or ""}

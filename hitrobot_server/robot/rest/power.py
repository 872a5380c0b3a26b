"""``RestPower``: battery, shutdown and reboot over the Slamware REST API.

The board temperature is not in the REST API: 0.
"""

from __future__ import annotations

from ..backend import PowerBackend
from ..model import PowerStatus
from . import paths, shapes
from .link import RestLink


class RestPower(PowerBackend):
    """The battery and the robot's power switch; switching off loses the link."""

    def __init__(self, link: RestLink) -> None:
        self._link = link

    async def get_power_status(self) -> PowerStatus:
        return await self._link.get(paths.POWER_STATUS, shapes.power_from)

    async def get_board_temperature(self) -> int:
        """Not in the REST API: 0 (the node publishes it in ``RobotBasicState``)."""
        self._link.require_connection()
        return 0

    async def power_off(self) -> None:
        """``POST power/:shutdown`` with both intervals 0 (shut down now; what a restart
        interval of 0 means is not documented), then treat the robot as gone."""
        await self._link.command("POST", paths.POWER_SHUTDOWN,
                                 {"shutdown_time_interval": 0, "restart_time_interval": 0})
        self._link.lose("shutting down on request")

    async def reboot(self) -> None:
        """``POST power/:restartmodule`` (``RestartModeSoft``: the Slamware software restarts),
        then treat the robot as gone; the connection task picks it up when it is back."""
        await self._link.command("POST", paths.POWER_RESTART_MODULE, {"mode": "RestartModeSoft"})
        self._link.lose("restarting on request")

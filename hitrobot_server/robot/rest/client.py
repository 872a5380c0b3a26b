"""``SlamwareRestBackend``: a real Slamware robot through its REST API (port 1448).

One adapter per capability, each over the shared :class:`~.link.RestLink` (the connection and
its requests, see :mod:`.link`): :class:`~.motion.RestMotion`,
:class:`~.localization.RestLocalization`, :class:`~.maps.RestMaps`,
:class:`~.sensors.RestSensors` and :class:`~.power.RestPower`. Each method is one or a few HTTP
calls (see :mod:`.paths`). While the robot is not connected every call raises
:class:`~hitrobot_server.robot.backend.NotConnectedError` without touching the network; the
node keeps serving its clients and resumes publishing on reconnect.

Where REST and the interface differ (see the README's real-robot section, and each adapter):
velocity control, ``APPENDING``, ``compute_path`` and ``RETURN_UNREACHABLE_DIRECTLY`` are
emulated (:mod:`.motion`); blocked areas become forbidden rectangle areas and ``add_lines``
cannot keep requested ids (:mod:`.maps`); basic sensors and the board temperature are not in
the REST API: none and 0.
"""

from __future__ import annotations

from ..composed import ComposedBackend
from ..model import Pose2D
from .link import BULK_TIMEOUT, CONTROL_TIMEOUT, TELEMETRY_TIMEOUT, RestLink
from .localization import RestLocalization
from .maps import RestMaps
from .motion import RestMotion
from .power import RestPower
from .sensors import RestSensors


class SlamwareRestBackend(ComposedBackend):
    """A Slamware robot at ``url`` (``http://192.168.11.1:1448``)."""

    link: RestLink
    localization: RestLocalization

    def __init__(
        self,
        url: str,
        reconn_wait_ms: int = 3000,
        *,
        timeout: float = TELEMETRY_TIMEOUT,
        control_timeout: float = CONTROL_TIMEOUT,
        bulk_timeout: float = BULK_TIMEOUT,
    ):
        link = RestLink(url, reconn_wait_ms, timeout=timeout, control_timeout=control_timeout,
                        bulk_timeout=bulk_timeout)
        localization = RestLocalization(link)
        maps = RestMaps(link)
        super().__init__(link, RestMotion(link, localization, maps), localization, maps,
                         RestSensors(link), RestPower(link))

    @property
    def url(self) -> str:
        return self.link.url

    async def get_odopose(self) -> Pose2D:
        """The odometry (dead-reckoning) pose; not part of a capability."""
        return await self.localization.get_odopose()

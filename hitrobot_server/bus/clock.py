"""The server's one clock: every stamp it produces is wall time (``time.time``, UNIX seconds).

Robot backends keep their own time (the simulator its simulated seconds, a real robot its
uptime); those values order a backend's own data and never reach a message header. Nodes
stamp what they publish with :attr:`Bus.clock`, which is this clock unless a test injects
another, so ``/scan``, ``/tf``, ``/odom`` and the point clouds agree with each other and with
rosapi's ``get_time``.
"""

from __future__ import annotations

import time

wall_clock = time.time


def ros_time(t: float) -> dict[str, int]:
    """Seconds as a ROS 1 ``time`` value (``secs``, ``nsecs``), never rounding up to 1e9 ns."""
    secs = int(t)
    return {"secs": secs, "nsecs": min(int((t - secs) * 1e9), 999_999_999)}

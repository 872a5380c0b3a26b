"""The sim-device: the built-in simulator behind the Slamware REST API, over real HTTP.

``hitrobot-server sim-device --port 1448`` (or :class:`SimDevice` in-process) serves the
endpoints :class:`~..rest.client.SlamwareRestBackend` uses, the way a robot does: paths with literal
``:`` segments, bare JSON booleans and numbers, octet-stream maps with the 36-byte header, 404
from ``actions/:current`` when idle, action status 0/1/3/4 with result 0/-1/-2, finished
actions read back as gravestones (no name, no stage), line ids chosen by the robot (requested
ids are ignored). It binds 127.0.0.1 by default.

It is a test double, not an emulator of every endpoint: see :data:`NOT_EMULATED`. Its command
line is :mod:`hitrobot_server.commands.sim_device`.

* :mod:`.server` - :class:`SimDevice`: the listener, its start and stop, errors, power;
* :mod:`.replies` - answers the way the robot words them, request bodies;
* :mod:`.slam` - pose, localization, mapping, home and the map itself;
* :mod:`.actions` - actions: started from their JSON, followed, cancelled;
* :mod:`.artifacts` - virtual lines and rectangle areas (forbidden ones block the planner).
"""

from .server import NOT_EMULATED, SimDevice

__all__ = ["NOT_EMULATED", "SimDevice"]

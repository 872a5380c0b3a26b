"""The robot side of the bridge: the backend boundary, its value types and the simulator.

Nodes talk to a robot's capabilities (:mod:`hitrobot_server.robot.backend`), bundled as a
:class:`~hitrobot_server.robot.capabilities.Robot` with the motion behind the locomotion gate;
the built-in simulator (:mod:`hitrobot_server.robot.sim`) and the Slamware REST client
(:mod:`hitrobot_server.robot.rest`) implement them, one adapter per capability each, and plan
with :mod:`hitrobot_server.robot.planning`, which sits below both.
"""

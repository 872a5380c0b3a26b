"""The robot side of the bridge: the backend boundary, its value types and the simulator.

The Slamware node talks to a :class:`~hitrobot_server.robot.backend.RobotBackend`; the built-in
simulator (:mod:`hitrobot_server.robot.sim`) and a future Slamware REST client implement it.
"""

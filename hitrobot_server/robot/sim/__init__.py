"""A simulated Slamware robot: pure Python/numpy, deterministic for a given seed.

:class:`~hitrobot_server.robot.sim.simulator.Simulator` owns the physics and the robot's
software stand-ins (mapping, localization, its actions; it plans with
:mod:`hitrobot_server.robot.planning`); :class:`~.runner.SimRunner` steps it on
the event loop and :class:`~.backend.SimBackend` exposes it as the REST robot is exposed: one
adapter per capability (:mod:`hitrobot_server.robot.backend`'s protocols) over the runner.
"""

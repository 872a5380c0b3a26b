"""hitrobot-server: a rosbridge-v2-compatible bridge with a simulated Slamware robot."""

__version__ = "0.1.0"

"""Worlds for the simulator, in ROS map_server format (YAML + PGM), and their generators."""

"""Recording the bus as MCAP (ROS 2 profile) and replaying a recording onto the bus."""

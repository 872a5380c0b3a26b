"""The ``slamware_ros_sdk_server_node`` interface on the bus, backed by any robot's capabilities."""

from .node import NODE_NAME, SlamwareNode

__all__ = ["NODE_NAME", "SlamwareNode"]

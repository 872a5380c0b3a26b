"""Names of nodes that other nodes address on the bus (a name, never the node's module)."""

MAP_MANAGER = "/map_manager"

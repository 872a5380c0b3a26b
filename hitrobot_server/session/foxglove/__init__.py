"""The Foxglove WebSocket protocol: one client's session, its op groups and frames."""

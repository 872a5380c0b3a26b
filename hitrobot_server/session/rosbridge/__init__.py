"""The rosbridge v2 protocol: one client's session, its op groups and their replies."""

"""The command-line tools besides the server itself (``hitrobot-server <tool> ...``)."""

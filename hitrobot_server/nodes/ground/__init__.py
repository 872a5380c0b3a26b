"""The nodes' ground floor: what several nodes share. It imports no node."""

"""Protocol conformance: a client-side runner for the JSON vectors in ``protocol/vectors``.

It talks to a server only over the wire, never through this package's server code, so the same
vectors can check this server, rosbridge or any other implementation of the protocol.
"""

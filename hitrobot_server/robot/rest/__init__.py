"""The Slamware REST API (port 1448): the client backend for real robots.

* :mod:`.client` - :class:`SlamwareRestBackend`, a ``ComposedBackend`` over aiohttp, made of
  one adapter per capability: :mod:`.motion`, :mod:`.localization`, :mod:`.maps`,
  :mod:`.sensors`, :mod:`.power`, each over :mod:`.link` (the connection and its requests);
* :mod:`.http` - the session wrapper (timeouts, one request in flight per resource);
* :mod:`.mapformat` - the binary explore map (36-byte header), sans I/O;
* :mod:`.shapes` - JSON ⇄ model conversions, pure;
* :mod:`.paths` - the endpoints.

The sim-device (the simulator served over the same API) is :mod:`..device`, above both this
package and ``sim/``.
"""

from .client import SlamwareRestBackend

__all__ = ["SlamwareRestBackend"]

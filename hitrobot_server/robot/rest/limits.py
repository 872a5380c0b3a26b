"""How much of a robot's answer the REST client reads, per endpoint.

A robot with a firmware bug, or a half-broken link, can answer anything: these bounds keep what
it sends from costing the server more than a real answer would. A body over its bound is not
read further (the connection is dropped) and the answer counts as nonsense
(:class:`~.http.BodyTooLarge`).

==============================  ============================================================
endpoint                        bound
==============================  ============================================================
``maps/explore``                the 36-byte header, then the cell bytes it declares, at most
                                :data:`MAX_MAP_CELLS`; what follows is not read
``maps/stcm``                   :data:`STCM_LIMIT` (the whole-map file, on request only)
laser scan, path, milestones,   :data:`LIST_LIMIT` (lists that grow with the robot's world)
lines, rectangle areas,
action factories
anything else                   :data:`JSON_LIMIT` (a pose, a status, a setter's answer)
==============================  ============================================================

A known area is refused when it would hold more than :data:`MAX_MAP_CELLS` cells at the map's
resolution, and an explore map's resolution must lie in :data:`RESOLUTIONS`.
"""

from __future__ import annotations

from . import paths

MiB = 1024 * 1024
JSON_LIMIT = 1 * MiB
LIST_LIMIT = 2 * MiB
STCM_LIMIT = 64 * MiB
MAX_MAP_CELLS = 8192 * 8192
"""64 Mi cells: a 409.6 m square at 5 cm. A map region, or the known area, over it is refused."""
RESOLUTIONS = (0.001, 10.0)
"""Metres per cell an explore map may have."""
MAP_HEADER = 36
"""The explore map's header (:data:`.mapformat.HEADER_SIZE`), read before its cells."""
PARSE_INLINE = 256 * 1024
"""Bodies up to this size are parsed on the event loop; bigger ones in a thread."""

_LISTS = (paths.LASERSCAN, paths.PATH, paths.MILESTONES, paths.LINES, paths.RECTANGLE_AREAS,
          paths.ACTION_FACTORIES)


def body_limit(path: str) -> int:
    """The most bytes an answer from ``path`` may have (the explore map's own bound is its
    header's: :func:`.mapformat.declared_size`)."""
    if path == paths.STCM:
        return STCM_LIMIT
    if path == paths.EXPLORE_MAP:
        return MAP_HEADER + MAX_MAP_CELLS
    if path.startswith(_LISTS):
        return LIST_LIMIT
    return JSON_LIMIT


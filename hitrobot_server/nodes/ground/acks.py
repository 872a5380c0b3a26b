"""One rule for acknowledgements: the table of which answers wait until the change is kept.

:data:`ACKS` names every service and request that changes what the site remembers, and the
reads beside them. A ``KEPT`` one is answered only once its change is on disk (and, over
``--bus zenoh``, applied at the other servers that keep a copy: the fleet's followers); a
refusal changed nothing and is answered at once. ``AT_ONCE`` ones change nothing the site keeps.
The rule is applied in one place, beside ``durable`` in :mod:`.memory`: the fleet's services
through ``acknowledged`` (where the fleet offers a service), the map manager's topic-borne
requests, answered by a status, through ``kept``. A name missing from the table is refused
where it is offered: a new change cannot skip the rule.
"""

from __future__ import annotations

KEPT = "kept"
"""Answered once the change is on disk (and at the followers)."""
AT_ONCE = "at once"
"""A read (or a change the site does not keep): answered as soon as it is done."""

ACKS: dict[str, str] = {
    # the fleet (nodes/fleet): the task board, its schedules, its robots out of service
    "/fleet/dispatch": KEPT,
    "/fleet/cancel": KEPT,
    "/fleet/pause": KEPT,
    "/fleet/resume": KEPT,
    "/fleet/set_in_service": KEPT,
    "/fleet/schedule_add": KEPT,
    "/fleet/schedule_remove": KEPT,
    "/fleet/zone_add": KEPT,
    "/fleet/zone_remove": KEPT,
    "/fleet/history": AT_ONCE,
    "/fleet/schedule_list": AT_ONCE,
    "/fleet/zone_list": AT_ONCE,
    "/fleet/zone_release": AT_ONCE,  # who holds a zone is not kept (it is found from poses)
    "/fleet/policy": AT_ONCE,
    # the map manager (nodes/map_manager): POIs, layer switches, masks (the walls), loaded map
    "add_poi": KEPT,
    "modify_poi": KEPT,
    "delete_poi": KEPT,
    "map_layers": KEPT,
    "modify_map": KEPT,
    "load_map": KEPT,
    "get_pois": AT_ONCE,
    "save_map": AT_ONCE,  # a map folder (written whole before its answer), not the site's state
    "do_mapping": AT_ONCE,  # the robot's: answered once the robot took it
    "/map": AT_ONCE,  # a client's map for the robot: likewise
}

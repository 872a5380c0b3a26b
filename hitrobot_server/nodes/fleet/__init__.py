"""The fleet: every named robot's state in one list, dispatch by cost, a task lifecycle with a
history, the charging policy, schedules and robots taken out of service.

Each named robot runs a :class:`FleetMemberNode` (on its namespaced view of the bus) that
publishes its state on the site-wide ``/fleet/members`` twice a second. The site's
:class:`FleetNode` collects them — from this server or, over ``--bus zenoh``, from others — and
serves (all ``hitrobot_msgs``):

* ``/fleet/robots`` (``FleetRobots``, latched, 2 Hz): name, pose, state
  (idle/moving/charging/error/offline), battery, dock, in service, current task.
* ``/fleet/dispatch`` (``Dispatch``): a POI or pose (``goto``), a ``sequence`` of POIs with
  dwell times, a ``patrol`` route for N laps; a priority; optionally a robot. Every capable robot
  bids its finish time; the reply names the winner and every bid (:mod:`.dispatch`).
* ``/fleet/tasks`` (``FleetTasks``, latched): open tasks and the last finished;
  ``/fleet/cancel``, ``/fleet/pause``, ``/fleet/resume`` (``CancelTask``).
* ``/fleet/history`` (``FleetHistory``): finished tasks, newest first, kept in the state folder.
* ``/fleet/schedule_add`` / ``_list`` / ``_remove``: recurring tasks (:mod:`.scheduling`).
* ``/fleet/set_in_service`` (``SetInService``): a robot out of service takes no task; its
  queued ones go to others.
* ``/fleet/zone_add`` / ``_list`` / ``_remove`` and the latched ``/fleet/zones``: mutex zones
  (a door, a narrow corridor) that one robot at a time may be in (:mod:`.zoning`); the robots'
  paths go through them by the rule of :mod:`.traffic`.

Over ``--bus zenoh`` the servers of a site keep one queue: one fleet node dispatches, the
others forward to it, keep a copy and take over when it dies (:mod:`.leader`, :mod:`.replica`).
"""

from .member import FleetMemberNode
from .node import FleetNode
from .policy import ChargePolicy

__all__ = ["ChargePolicy", "FleetMemberNode", "FleetNode"]

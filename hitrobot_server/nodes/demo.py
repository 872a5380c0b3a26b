"""The tutorial servers of the rosbridge test image, behind ``--demo-services`` (off by default).

Client test suites (roslibpy's, roslibjs's examples) expect a ``/add_two_ints`` service and a
``/fibonacci`` action next to rosbridge; the types are the ROS 2 tutorial ones
(``example_interfaces``). ``/fibonacci`` grows the sequence one term per
:data:`FIBONACCI_PERIOD`, 1 s as the ROS 2 tutorial server (roslibpy's own suite cancels an
order-8 goal 3 s after sending it, so a faster one would have ended), with the sequence so far
as feedback; as in the tutorial the
sequence starts ``[0, 1]`` and ends with the ``order``-th Fibonacci number.
"""

from __future__ import annotations

import asyncio
import contextlib

from ..bus.core import Bus
from ..bus.errors import ServiceError
from ..bus.services import (
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    GoalHandle,
    GoalOutcome,
)
from .base import Node

ADD_TWO_INTS = "/add_two_ints"
FIBONACCI = "/fibonacci"
FIBONACCI_PERIOD = 1.0
"""Seconds per term of ``/fibonacci`` (the ROS 2 tutorial's rate: one term a second)."""
MAX_ORDER = 46
"""The largest order whose sequence fits the result's ``int32[]`` (F(47) does not)."""
INT64 = (-(2**63), 2**63 - 1)


class DemoServices(Node):
    """``/add_two_ints`` (example_interfaces/srv/AddTwoInts) and ``/fibonacci``
    (example_interfaces/action/Fibonacci)."""

    # its node name is left out: the demo runs beside a single robot only, never a named one
    GLOBAL_NAMES = (ADD_TWO_INTS, FIBONACCI)

    def __init__(self, bus: Bus):
        super().__init__(bus, "/demo_services")
        self.service(ADD_TWO_INTS, "example_interfaces/srv/AddTwoInts", self._add_two_ints)
        self.action(FIBONACCI, "example_interfaces/action/Fibonacci", self._fibonacci)

    async def _add_two_ints(self, request: dict) -> dict:
        total = int(request.get("a", 0)) + int(request.get("b", 0))
        if not INT64[0] <= total <= INT64[1]:
            raise ServiceError(f"the sum {total} does not fit int64")
        return {"sum": total}

    async def _fibonacci(self, goal: GoalHandle) -> GoalOutcome:
        order = int(goal.goal.get("order", 0))
        if not 0 <= order <= MAX_ORDER:
            return GoalOutcome(STATUS_ABORTED,
                               f"field 'order' must be 0..{MAX_ORDER}, got {order}", False)
        sequence = [0, 1]
        while len(sequence) <= order:
            if goal.cancelled.is_set():
                return GoalOutcome(STATUS_CANCELED, {"sequence": sequence}, True)
            sequence.append(sequence[-1] + sequence[-2])
            goal.feedback({"sequence": list(sequence)})
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(goal.cancelled.wait(), FIBONACCI_PERIOD)
        if goal.cancelled.is_set():
            return GoalOutcome(STATUS_CANCELED, {"sequence": sequence}, True)
        return GoalOutcome(STATUS_SUCCEEDED, {"sequence": sequence}, True)

"""The rosbridge ops the server sends, built in one place (sans-I/O): the answers to a client's
calls and goals, and the requests it is handed as a provider. ``status`` is
:func:`.errors.status_op`; a topic's ``publish`` is the wire floor's (its body encoded once
for every subscriber). An ``id`` is left out when the request had none, as the spec's optional
field says."""

from __future__ import annotations

from typing import Any

from .errors import MessageId


def _with_id(op: dict, id: MessageId) -> dict:
    if id is not None:
        op["id"] = id
    return op


def service_response(service: str, id: MessageId, values: Any, result: bool) -> dict:
    """The answer to a ``call_service`` (``values``: the response, or why it failed)."""
    op = _with_id({"op": "service_response", "service": service}, id)
    op["values"] = values
    op["result"] = result
    return op


def action_result(action: str, id: MessageId, values: Any, status: int, result: bool) -> dict:
    """The end of a goal sent with ``send_action_goal``."""
    op = _with_id({"op": "action_result", "action": action}, id)
    op["values"] = values
    op["status"] = status
    op["result"] = result
    return op


def action_feedback(action: str, id: MessageId, values: Any) -> dict:
    """A running goal's feedback."""
    op = _with_id({"op": "action_feedback", "action": action}, id)
    op["values"] = values
    return op


def call_service(id: str, service: str, args: Any) -> dict:
    """A call handed to the client that provides ``service``."""
    return {"op": "call_service", "id": id, "service": service, "args": args}


def send_action_goal(id: str, action: str, action_type: str, args: Any) -> dict:
    """A goal handed to the client that provides ``action`` (its feedback is asked for)."""
    return {"op": "send_action_goal", "id": id, "action": action, "action_type": action_type,
            "args": args, "feedback": True}


def cancel_action_goal(id: str, action: str) -> dict:
    """A goal handed to a providing client was cancelled."""
    return {"op": "cancel_action_goal", "id": id, "action": action}

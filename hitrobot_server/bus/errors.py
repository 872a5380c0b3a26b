"""Errors raised by the bus; sessions turn them into ``status`` messages or failed replies."""


class BusError(Exception):
    """A request the bus refuses (unknown resource, type conflict, ...); the text is user-facing."""


class ServiceError(BusError):
    """A service call failed; the text becomes the failed ``service_response`` values."""


class ActionError(BusError):
    """An action goal could not be sent or was rejected."""

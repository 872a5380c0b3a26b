"""Errors raised by the bus; sessions turn them into ``status`` messages or failed replies."""


class BusError(Exception):
    """A request the bus refuses (unknown resource, type conflict, ...); the text is user-facing."""


class ServiceError(BusError):
    """A service call failed; the text becomes the failed ``service_response`` values, unless
    the provider gave its own ``values`` with ``result: false`` (rosbridge passes those on)."""

    def __init__(self, text: str, values: dict | None = None):
        super().__init__(text)
        self.values = values


class ActionError(BusError):
    """An action goal could not be sent or was rejected."""

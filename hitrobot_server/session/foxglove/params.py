"""Parameters: ``getParameters``, ``setParameters`` and parameter updates to subscribers,
within what ``--params-glob`` allows."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...bus.names import canonical, valid_name
from ...bus.params import ParamError
from ...protocol import foxglove as fg

if TYPE_CHECKING:
    from .context import FoxgloveContext


class ParamOps:
    def __init__(self, client: FoxgloveContext):
        self.client = client
        self.param_subs: set[str] = set()

    def get(self, op: fg.GetParameters) -> None:
        """The values of the names asked (every leaf when none), those --params-glob allows
        and that are set; any other name is left out, as the spec's reply allows."""
        params, allowed = self.client.bus.params, self.client.settings.params_filter.allows
        names = op.parameter_names or params.names()
        values = [fg.param_to_wire(n, params.get(n)) for n in names
                  if valid_name(n) and allowed(n) and params.has(n)]
        self.client.out.send(fg.parameter_values(values, op.id))

    def set(self, op: fg.SetParameters) -> None:
        pairs = list(op.parameters)
        for name, _value in pairs:  # validate all first, then set
            if not valid_name(name) or canonical(name) == "/":
                raise fg.FoxgloveError(f"setParameters: field 'name' {name!r:.80} is not a valid "
                                       "parameter name")
            if not self.client.settings.params_filter.allows(name):
                raise fg.FoxgloveError(f"setParameters: parameter '{canonical(name)}' is not "
                                       "allowed by --params-glob")
        params = self.client.bus.params
        try:
            params.update(pairs)  # all or none
        except ParamError as exc:
            raise fg.FoxgloveError(f"setParameters: {exc}; no parameter was set") from None
        if op.id is not None:
            values = [fg.param_to_wire(n, params.get(n)) if params.has(n) else {"name": n}
                      for n, _v in pairs]
            self.client.out.send(fg.parameter_values(values, op.id))

    def subscribe(self, op: fg.SubscribeParameterUpdates) -> None:
        self.param_subs.update(canonical(n) for n in op.parameter_names)

    def unsubscribe(self, op: fg.UnsubscribeParameterUpdates) -> None:
        self.param_subs.difference_update(canonical(n) for n in op.parameter_names)

    def changed(self, name: str) -> None:
        """A parameter changed on the bus: its new value to a client subscribed to it."""
        if not self.param_subs:
            return
        params, allowed = self.client.bus.params, self.client.settings.params_filter.allows
        hit = [n for n in self.param_subs if allowed(n) and (
               n == name or n.startswith(name.rstrip("/") + "/") or name.startswith(n + "/"))]
        if hit:
            self.client.out.send(fg.parameter_values(
                [fg.param_to_wire(n, params.get(n)) if params.has(n) else {"name": n}
                 for n in sorted(hit)]
            ))

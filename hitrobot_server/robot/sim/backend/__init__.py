"""``SimBackend``: the simulated robot as the REST robot is built, one adapter per capability
over what steps it (:class:`~..runner.SimRunner`), composed by
:class:`~hitrobot_server.robot.composed.ComposedBackend`.

:mod:`.link` (start, stop: the runner's), :mod:`.motion`, :mod:`.localization`, :mod:`.maps`,
:mod:`.sensors`, :mod:`.power`, and :mod:`.controls`, the simulator's own (battery, kidnap,
emergency stop), which no real robot has. Each is a :class:`~..runner.RunnerPart`: the runner
refuses a request while the simulator is stopped, words its ``ValueError`` as a
``BackendError`` and answers a change once on disk.
"""

from __future__ import annotations

from ...composed import ComposedBackend
from ..persist import SimMemory
from ..runner import SimRunner
from ..simulator import Simulator
from .controls import SimControls
from .link import SimLink
from .localization import SimLocalization
from .maps import SimMaps
from .motion import SimMotion
from .power import SimPower
from .sensors import SimSensors


class SimBackend(ComposedBackend):
    """A :class:`Simulator` as a robot backend; :attr:`runner` steps it on the event loop."""

    link: SimLink

    def __init__(self, simulator: Simulator, rate_hz: float = 20.0, time_scale: float = 1.0,
                 memory: SimMemory | None = None):
        if rate_hz <= 0.0 or time_scale <= 0.0:
            raise ValueError("rate_hz and time_scale must be positive")
        restored = memory.restore(simulator) if memory is not None else []
        self.runner = runner = SimRunner(simulator, rate_hz, time_scale, memory)
        super().__init__(SimLink(runner), SimMotion(runner), SimLocalization(runner),
                         SimMaps(runner), SimSensors(runner), SimPower(runner), restored)
        self.controls = SimControls(runner)
        """The simulator's own controls (``/sim/…``)."""

    @property
    def simulator(self) -> Simulator:
        """The simulator now running (a reboot replaces it)."""
        return self.runner.simulator


__all__ = ["SimBackend"]

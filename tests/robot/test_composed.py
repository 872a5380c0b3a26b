"""``ComposedBackend``: every backend is one adapter per capability, each implementing every
method of its protocol; nothing is forwarded, and the nodes get the adapters themselves
(``robot_of``)."""

from __future__ import annotations

from hitrobot_server.robot.backend import (
    Link,
    LocalizationBackend,
    MapBackend,
    MotionBackend,
    PowerBackend,
    SensorBackend,
)
from hitrobot_server.robot.composed import ComposedBackend
from hitrobot_server.robot.factory import build_simulator, robot_of
from hitrobot_server.robot.locomotion import GatedMotion
from hitrobot_server.robot.rest.client import SlamwareRestBackend
from hitrobot_server.robot.rest.link import RestLink
from hitrobot_server.robot.rest.localization import RestLocalization
from hitrobot_server.robot.rest.maps import RestMaps
from hitrobot_server.robot.rest.motion import RestMotion
from hitrobot_server.robot.rest.power import RestPower
from hitrobot_server.robot.rest.sensors import RestSensors
from hitrobot_server.robot.sim.backend import SimBackend

PROTOCOLS = (Link, MotionBackend, LocalizationBackend, MapBackend, SensorBackend, PowerBackend)


def capabilities(backend: ComposedBackend) -> tuple:
    return (backend.link, backend.motion, backend.localization, backend.maps, backend.sensors,
            backend.power)


def test_every_capability_method_is_forwarded():
    """No forwarding is left to miss a method: each backend's adapter of a capability
    implements every method of its protocol (an abstract one left would refuse to build), and
    the locomotion gate names every motion method."""
    methods = {name for protocol in PROTOCOLS for name in vars(protocol)
               if not name.startswith("_")}
    assert methods, "the protocols declare methods"
    for backend in (SlamwareRestBackend("http://192.0.2.1:1448"),
                    SimBackend(build_simulator())):
        for part, protocol in zip(capabilities(backend), PROTOCOLS, strict=True):
            own = {name for name in vars(protocol) if not name.startswith("_")}
            assert sorted(own - set(dir(part))) == []
            assert not type(part).__abstractmethods__
    motion = {name for name in vars(MotionBackend) if not name.startswith("_")}
    assert sorted(motion - set(vars(GatedMotion))) == []
    assert not set(vars(ComposedBackend)) & methods  # nothing of a capability forwarded


def test_the_rest_backend_is_one_adapter_per_capability_handed_to_the_robot():
    backend = SlamwareRestBackend("http://192.0.2.1:1448")
    parts = (backend.link, backend.motion, backend.localization, backend.maps, backend.sensors,
             backend.power)
    kinds = (RestLink, RestMotion, RestLocalization, RestMaps, RestSensors, RestPower)
    assert [type(part) for part in parts] == list(kinds)
    for part, protocol in zip(parts, PROTOCOLS, strict=True):
        assert protocol in type(part).__mro__  # each adapter implements its capability
    robot = robot_of(backend)
    assert robot.link is backend.link and robot.localization is backend.localization
    assert robot.maps is backend.maps and robot.sensors is backend.sensors
    assert robot.power is backend.power
    assert robot.motion.inner is backend.motion  # behind the locomotion gate
    assert robot.locomotion.link is backend.link and robot.locomotion.motion is backend.motion

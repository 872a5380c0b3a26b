"""``ComposedBackend``: a backend made of one adapter per capability forwards every method of
every capability protocol, and the nodes get the adapters themselves (``robot_of``)."""

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
from hitrobot_server.robot.factory import robot_of
from hitrobot_server.robot.rest.client import SlamwareRestBackend
from hitrobot_server.robot.rest.link import RestLink
from hitrobot_server.robot.rest.localization import RestLocalization
from hitrobot_server.robot.rest.maps import RestMaps
from hitrobot_server.robot.rest.motion import RestMotion
from hitrobot_server.robot.rest.power import RestPower
from hitrobot_server.robot.rest.sensors import RestSensors

PROTOCOLS = (Link, MotionBackend, LocalizationBackend, MapBackend, SensorBackend, PowerBackend)


def test_every_capability_method_is_forwarded():
    methods = {name for protocol in PROTOCOLS for name in vars(protocol)
               if not name.startswith("_")}
    assert methods, "the protocols declare methods"
    assert sorted(methods - set(vars(ComposedBackend))) == []


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

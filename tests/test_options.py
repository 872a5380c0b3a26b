"""Each layer's options own their settings: a help text and a default in one field, nowhere
else; the flags and the TOML keys follow from them (config.py only composes)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields
from pathlib import Path

import pytest

from hitrobot_server.cli import build_parser
from hitrobot_server.config import FLAG_ORDER, SECTIONS, Settings, declared, load, shown_default
from hitrobot_server.robot.options import RobotEntry
from hitrobot_server.robots import start_plan

# Fields of the sections that are not settings: handed down from another layer's setting, or
# learnt at start. Each has no help text; a handed-down one has no default either.
HANDED_DOWN = {"map_store", "slamware", "authenticate", "topics_glob", "services_glob",
               "params_glob"}  # NodeOptions: the store's, [slamware], the sessions'
NOT_SETTINGS = {
    "NodeOptions": HANDED_DOWN | {"time_scale", "fleet_clock"},  # sim_speed per robot; a
    # clock tests hand the fleet (its schedules on a held clock)
    "SessionOptions": {"auth_secret", "client_tag"},  # learnt at start (for_sessions)
    "RobotOptions": {"reconn_wait_ms", "start"},  # [slamware]; one robot's start pose
}


def defaults_written_twice(kinds: list[type]) -> list[str]:
    """Settings (fields with a help text) whose name has a default in another class too."""
    owners = {name: kind for kind in kinds for name in declared(kind)}
    return [f"{f.name}: {owners[f.name].__name__} and {kind.__name__}"
            for kind in kinds for f in fields(kind)
            if f.name in owners and owners[f.name] is not kind
            and (f.default is not dataclasses.MISSING
                 or f.default_factory is not dataclasses.MISSING)]


def test_every_field_of_every_section_is_a_documented_setting():
    for kind in SECTIONS.values():
        settings = declared(kind)
        for f in fields(kind):
            if not f.init or f.name in NOT_SETTINGS.get(kind.__name__, ()):
                assert f.name not in settings
                continue
            assert f.name in settings, f"{kind.__name__}.{f.name} has no help text"
            assert f.metadata["help"].strip() and f.default is not dataclasses.MISSING


def test_every_setting_is_one_flag_in_the_help_order_declared_once():
    names = [name for kind in SECTIONS.values() for name in declared(kind)]
    assert len(names) == len(set(names))  # no setting declared by two layers
    assert sorted(FLAG_ORDER) == sorted(names) and len(FLAG_ORDER) == len(set(FLAG_ORDER))


def test_no_default_is_written_twice():
    assert defaults_written_twice(list(SECTIONS.values())) == []
    node_fields = {f.name: f for f in fields(SECTIONS["nodes"])}
    for name in HANDED_DOWN - {"slamware"}:  # its owner's default is the one
        assert node_fields[name].default is dataclasses.MISSING


def test_the_rule_catches_a_second_default():
    @dataclass
    class Owner:
        port: int = field(default=1, metadata={"help": "the port"})

    @dataclass
    class Copy:
        port: int = 1

    assert defaults_written_twice([Owner, Copy]) == ["port: Owner and Copy"]


def test_flag_defaults_and_help_come_from_the_fields():
    parser = build_parser()
    actions = {a.dest: a for a in parser._actions}
    defaults = load(parser.parse_args([]))
    for kind_name, kind in SECTIONS.items():
        section = getattr(defaults, kind_name)
        for name, f in declared(kind).items():
            assert actions[name].default is None  # so the TOML file can fill it
            assert actions[name].help == shown_default(f)
            assert getattr(section, name) == f.default, name


def test_toml_and_flags_reach_their_layer(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[server]\nsend_buffer_limit = 5\nrecord-split-size = 2\nworkers = 3\n'
                   '[slamware]\nreconn_wait_ms = 250\n')
    s = load(build_parser().parse_args(["--config", str(cfg), "--map-dir", str(tmp_path),
                                        "--topics-glob", "/a/*"]))
    assert s.session.send_buffer_limit == 5 and s.record.split_bytes == 2 * 1024 * 1024
    assert s.process.workers == "3" and s.robot.reconn_wait_ms == 250
    assert s.nodes.map_store == Path(tmp_path) and s.nodes.topics_glob == "/a/*"
    with pytest.raises(TypeError, match="prot"):
        Settings.of(prot=1)


def test_settings_and_options_are_frozen():
    s = Settings.of()
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.worker_id = 1  # type: ignore[misc]
    for name, kind in SECTIONS.items():
        first = fields(kind)[0].name
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(getattr(s, name), first, None)


def test_the_sessions_get_the_start_values_and_the_fragment_floor():
    options = Settings.of(max_message_size=100).session
    given = options.for_sessions("secret", "abc_")
    assert (given.auth_secret, given.client_tag, given.max_message_size) == ("secret", "abc_",
                                                                             1024)
    assert options.max_message_size == 100 and options.auth_secret is None


def test_the_plan_says_what_starts(tmp_path):
    plan = start_plan(Settings.of(robot="none", tcp_port=0))
    assert plan.robots == (RobotEntry("", "none"),) and not plan.fleet and not plan.tcp
    assert plan.primary and not plan.worker and not plan.zenoh and plan.record is None
    assert not plan.demo and start_plan(Settings.of(demo_services=True)).demo
    named = (RobotEntry("a", "sim"), RobotEntry("b", "sim"))
    fleet = start_plan(Settings.of(robots=named, record=str(tmp_path / "r.mcap"), bus="zenoh"))
    assert fleet.fleet and fleet.robots == named and fleet.zenoh
    assert fleet.record == tmp_path / "r.mcap"
    assert not start_plan(Settings.of(robots=named, demo_services=True)).demo  # single only
    second = start_plan(Settings.of(robots=named, worker_id=1))
    assert second.robots == () and not second.fleet and not second.primary and second.worker
    assert start_plan(Settings.of(worker_id=0)).primary
    assert start_plan(Settings.of(), robot="none").robots == (RobotEntry("", "none"),)

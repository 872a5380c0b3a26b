"""The console's ROS names live in web/names.js only: no other module spells a topic, service or
action name (each imports it from there), every name a module takes from there exists, and a
fleet robot's names are the same names under /NAME/. The current-robot store (currentrobot.js)
tells its followers, in order, when another robot is chosen."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.web.jssource import string_literals

WEB = Path(__file__).resolve().parents[2] / "web"
NAMES = WEB / "names.js"
MODULES = sorted(p for p in WEB.glob("*.js") if p.name != "names.js")
# HTTP paths the console builds that look like ROS names (a '/' then a word). There are none:
# the recordings' download links are relative (`recordings/NAME`).
HTTP_PATHS: frozenset[str] = frozenset()

# a quoted '/word…', or a template that puts '/word…' after an interpolated prefix
ROS_NAME = re.compile(r"^(/[A-Za-z_~]|\$\{[^}]*\}/[A-Za-z_])")
GROUPS = ("TOPICS", "SERVICES", "ACTIONS", "DIAGNOSTICS")


def literal_names(path: Path) -> list[str]:
    """The string literals of a module that look like ROS names, with their line."""
    return [f"{path.name}:{lit.line}: {lit.text!r}" for lit in string_literals(path)
            if ROS_NAME.match(lit.text) and lit.text not in HTTP_PATHS]


def defined_names() -> dict[str, set[str]]:
    """The keys of each frozen group of names.js (TOPICS, SERVICES, ...)."""
    source = NAMES.read_text()
    groups = {}
    for group in GROUPS:
        body = re.search(rf"export const {group} = Object\.freeze\(\{{(.*?)\n\}}\);", source,
                         re.DOTALL)
        assert body, f"names.js has no {group}"
        groups[group] = set(re.findall(r"^\s+(\w+):", body.group(1), re.MULTILINE))
    return groups


def test_no_module_but_names_js_spells_a_ros_name():
    found = [hit for path in MODULES for hit in literal_names(path)]
    assert found == [], "ROS names belong in web/names.js:\n" + "\n".join(found)


def test_no_module_defines_the_slamware_node_again():
    found = [f"{p.name}:{lit.line}" for p in MODULES for lit in string_literals(p)
             if "slamware_ros_sdk_server_node" in lit.text]
    assert found == []
    assert not [p.name for p in MODULES if re.search(r"\bconst NODE\b", p.read_text())]


def test_every_name_a_module_uses_is_defined():
    groups = defined_names()
    missing = [f"{p.name}: {group}.{key}" for p in MODULES
               for group, key in re.findall(rf"\b({'|'.join(GROUPS)})\.(\w+)", p.read_text())
               if key not in groups[group]]
    assert missing == []


def test_the_modules_that_use_names_import_them():
    for path in MODULES:
        source = path.read_text()
        used = {g for g in (*GROUPS, "SLAMWARE_NODE") if re.search(rf"\b{g}\b", source)}
        if not used:
            continue
        imported = re.search(r"import \{([^}]*)\} from './names\.js';", source)
        assert imported, f"{path.name} uses {used} without importing names.js"
        assert used <= {n.strip() for n in imported.group(1).split(",")}, path.name


def test_the_source_check_catches_a_literal_name(tmp_path):
    """The check itself: a name in a string or a template is caught; one in a comment, a
    regular expression (even one with a quote in it) or a message type is not."""
    module = tmp_path / "panel.js"
    module.write_text(
        "// subscribes to '/comment/only'\n"
        "/* and '/block/comment' */\n"
        "const plain = text.replace(/^publish to '[^']*': /, '');\n"
        "const type = 'geometry_msgs/Twist';\n"
        "const a = new ROSLIB.Topic({ ros, name: '/cmd_vel', messageType: type });\n"
        "const b = `${ns}/navigation/navigate_to_poi`;\n"
        "const c = `robot ${name} at ${`/nested/${x}`}`;\n"
        'const d = "/double_quoted";\n')
    assert literal_names(module) == [
        "panel.js:5: '/cmd_vel'",
        "panel.js:6: '${ns}/navigation/navigate_to_poi'",
        "panel.js:7: '/nested/${x}'",
        "panel.js:8: '/double_quoted'",
    ]


NODE_CHECK = """
import { ACTIONS, SLAMWARE_NODE, TOPICS, robotName } from './names.js';
import { CurrentRobot } from './currentrobot.js';

const heard = [];
const robot = new CurrentRobot();
const before = robot.nameOf(TOPICS.cmdVel);
robot.follow((name) => heard.push(`first ${name} ${robot.nameOf(TOPICS.cancelAction)}`));
robot.follow((name) => heard.push(`second ${name} ${robot.nameOf(ACTIONS.moveBase)}`));
robot.set('a');
robot.set('a');  // the same robot again: nobody hears it
robot.set('b');
let frozen;
try {
  TOPICS.cmdVel = '/elsewhere';
  frozen = TOPICS.cmdVel === '/cmd_vel';
} catch {
  frozen = true;  // a module's code is strict: writing to a frozen object throws
}
console.log(JSON.stringify({
  before, heard, frozen, node: SLAMWARE_NODE,
  single: robotName(null, TOPICS.scan), fleet: robotName('a', TOPICS.scan),
}));
"""


def test_names_and_the_current_robot_in_node(tmp_path):
    """names.js and currentrobot.js need no browser: run them under Node."""
    if shutil.which("node") is None:
        pytest.skip("node is not installed")
    for name in ("names.js", "currentrobot.js"):
        shutil.copy(WEB / name, tmp_path / name)
    (tmp_path / "package.json").write_text('{"type": "module"}')
    (tmp_path / "check.js").write_text(NODE_CHECK)
    run = subprocess.run(["node", str(tmp_path / "check.js")], capture_output=True, text=True,
                         timeout=30)
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result == {
        "before": "/cmd_vel",
        "heard": [
            "first a /a/slamware_ros_sdk_server_node/cancel_action",
            "second a /a/move_base",
            "first b /b/slamware_ros_sdk_server_node/cancel_action",
            "second b /b/move_base",
        ],
        "frozen": True,
        "node": "/slamware_ros_sdk_server_node",
        "single": "/slamware_ros_sdk_server_node/scan",
        "fleet": "/a/slamware_ros_sdk_server_node/scan",
    }

"""Ship the top-level ``schemas/``, ``protocol/`` and ``web/`` folders inside the package.

The repository layout keeps them at the top level (they are language-neutral); an installed
server still needs them, so they are mapped to ``hitrobot_server._schemas``,
``hitrobot_server._protocol`` and ``hitrobot_server._web``. The web console's libraries come
from npm (``npm ci --prefix web``, run before ``pip install .``); only the browser builds the
page loads are shipped, with their licences, never the rest of ``node_modules``. Everything
else is in pyproject.toml.
"""

import sys
from pathlib import Path

from setuptools import find_packages, setup

DATA = {
    "hitrobot_server._schemas": "schemas",
    "hitrobot_server._protocol": "protocol",
    "hitrobot_server._web": "web",
}

# The web console: our own files, and the browser builds of the npm libraries it loads.
WEB_FILES = [
    "*.html",
    "*.js",
    "*.css",
    "*.svg",
    "node_modules/eventemitter2/lib/eventemitter2.js",
    "node_modules/eventemitter2/LICENSE.txt",
    "node_modules/easeljs/lib/easeljs.min.js",
    "node_modules/easeljs/LICENSE.txt",
    "node_modules/roslib/build/roslib.min.js",
    "node_modules/roslib/LICENSE",
    "node_modules/ros2d/build/ros2d.min.js",
    "node_modules/ros2d/LICENSE",
]

HERE = Path(__file__).resolve().parent
SHIPPED = {
    "hitrobot_server._schemas": ["*/*/*.msg", "*/*/*.srv", "*/*/*.action"],
    "hitrobot_server._protocol": ["*.md", "schemas/*.json", "vectors/*.json", "vda5050/*.schema",
                                  "vda5050/*.txt", "vda5050/*.md"],
    "hitrobot_server._web": WEB_FILES,
}


def data_packages() -> dict[str, list[str]]:
    """Every folder holding shipped files as a package of its own, with its file patterns.

    setuptools treats a folder of package data as an importable (namespace) package and warns
    once per folder that is not in ``packages``; listing each such folder with its own
    ``package_data`` describes the same files without the ambiguity.
    """
    packages: dict[str, list[str]] = {}
    for package, patterns in SHIPPED.items():
        root = HERE / DATA[package]
        packages.setdefault(package, [])
        for pattern in patterns:
            folder, _, name = pattern.rpartition("/")
            for found in sorted(root.glob(folder)) if folder else [root]:
                if found.is_dir() and any(found.glob(name)):
                    sub = ".".join((package, *found.relative_to(root).parts))
                    packages.setdefault(sub, [])
                    if name not in packages[sub]:
                        packages[sub].append(name)
    return packages


if not (HERE / "web" / "node_modules" / "roslib").is_dir():
    print("warning: web/node_modules is missing, so the web console will lack its libraries; "
          "run `npm ci --prefix web` before installing", file=sys.stderr)

DATA_PACKAGES = data_packages()

setup(
    packages=find_packages(include=["hitrobot_server", "hitrobot_server.*"]) + list(DATA_PACKAGES),
    package_dir={"": ".", **DATA},
    package_data={
        "hitrobot_server": ["py.typed", "robot/worlds/*.yaml", "robot/worlds/*.pgm"],
        **DATA_PACKAGES,
    },
)

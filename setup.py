"""Ship the top-level ``schemas/`` and ``protocol/`` folders inside the package.

The repository layout keeps them at the top level (they are language-neutral); an installed
server still needs them, so they are mapped to ``hitrobot_server._schemas`` and
``hitrobot_server._protocol``. Everything else is in pyproject.toml.
"""

from setuptools import find_packages, setup

DATA = {"hitrobot_server._schemas": "schemas", "hitrobot_server._protocol": "protocol"}

setup(
    packages=find_packages(include=["hitrobot_server", "hitrobot_server.*"]) + list(DATA),
    package_dir={"": ".", **DATA},
    package_data={
        "hitrobot_server": ["py.typed", "robot/worlds/*.yaml", "robot/worlds/*.pgm"],
        "hitrobot_server._schemas": ["*/*/*.msg", "*/*/*.srv", "*/*/*.action"],
        "hitrobot_server._protocol": ["*.md", "schemas/*.json", "vectors/*.json"],
    },
)

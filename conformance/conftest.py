"""Loads the conformance plugin when pytest runs this folder (``pytest conformance --target URL``)."""
from buildhat_conformance.conformance.fixtures import empty_port, motor_port, second_motor_port  # noqa: E402,F401
from buildhat_conformance.conformance.plugin import *  # noqa: F401,F403
from buildhat_conformance.conformance.plugin import (  # noqa: F401 - hooks and fixtures pytest must see
    _conformance_case,
    _run,
    _world_changes,
    hat,
    pytest_addoption,
    pytest_configure,
    verdict,
    world,
)

# H10: several targets at once (xdist, one worker per HAT); inert with a single target.
pytest_plugins = ["buildhat_conformance.conformance.multitarget"]

"""Fixtures a test names: where it records its verdict, the world around the HAT, and the
device it needs (it gets the port it is on)."""
from __future__ import annotations

from typing import Any, Dict

import pytest

from ..hat_under_test import HatUnderTest
from ..needs import PortNeeds
from ..plugin.run import SuiteRun, _verdict_key
from ..probes import MOTOR
from ..verdict import Verdict


@pytest.fixture
def verdict(request: Any) -> Verdict:
    """Where a test records known deviations and notes (see :class:`~.verdict.Verdict`)."""
    return request.node.stash[_verdict_key]


@pytest.fixture(scope="session")
def _world_changes(_run: SuiteRun, pytestconfig: Any) -> Any:
    """The ports the run changed and what they had before; put back when the run ends
    (unless the HAT ends with the run: an emulator the target started itself, or the run
    stopped talking to it)."""
    original: Dict[int, Any] = {}
    yield original
    if original and _run.hat is not None and _run.tee is not None and not _run.tee.dead \
            and not _run.tee.disposable:
        PortNeeds(_run.hat, pytestconfig, original).restore()


@pytest.fixture
def world(hat: HatUnderTest, pytestconfig: Any, _world_changes: Dict[int, Any]) -> Any:
    """Devices and world actions a test needs. Devices stay for the next test (which states
    its own needs); the run puts everything back at its end."""
    return PortNeeds(hat, pytestconfig, _world_changes)


@pytest.fixture
def motor_port(world: Any) -> int:
    """A port with a SPIKE Prime medium motor (0x30) established."""
    return world.active(MOTOR)


@pytest.fixture
def second_motor_port(world: Any, motor_port: int) -> int:
    """Another port with a 0x30 motor (for per-port independence)."""
    return world.active(MOTOR, avoid=(motor_port,))


@pytest.fixture
def empty_port(world: Any) -> int:
    return world.empty_port()

"""Device fixtures: a test names the device it needs and gets the port it is on."""
from __future__ import annotations

from typing import Any

import pytest

from .probes import MOTOR


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

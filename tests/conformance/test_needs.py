"""The suite's world bookkeeping (conformance/needs.py) against a real emulator: devices a
test plugged stay for the next test, and the run puts every changed port back at its end."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from buildhat_conformance.conformance.hat_under_test import HatUnderTest
from buildhat_conformance.conformance.needs import PortNeeds
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target

pytestmark = pytest.mark.timeout(120)

URL = "emulator:R7?speed=10"
SENSOR = ("active", 0x3D)        # a colour sensor: not in the default layout


@pytest.fixture
def hat():
    target = make_target(URL)
    session = Session(target).open()
    while not target.control.action("@settled").strip().endswith("1"):   # the default layout is up
        session.wait_ms(50)
    yield HatUnderTest(session, target, URL)
    session.close()


def _config() -> SimpleNamespace:
    return SimpleNamespace(getoption=lambda name: False)


def _layout(world: PortNeeds) -> dict:
    return {e.port: world.spec_of(e) for e in world.layout()}


def test_devices_stay_between_tests_and_the_run_puts_them_back(hat: HatUnderTest) -> None:
    changes: dict = {}
    first = PortNeeds(hat, _config(), changes)
    before = _layout(first)
    port = first.active(SENSOR[1])
    assert _layout(first)[port] == SENSOR
    # The next test finds the sensor where the last one left it: no plugging.
    second = PortNeeds(hat, _config(), changes)
    assert second.active(SENSOR[1]) == port
    assert changes == {port: before[port]}
    empty = second.empty_port(avoid=(port,))
    assert _layout(second)[empty] is None
    PortNeeds(hat, _config(), changes).restore()
    assert _layout(first) == before
    assert changes == {}


def test_waiting_for_a_device_ends_once_it_is_up(hat: HatUnderTest) -> None:
    """The wait for a plugged device follows the HAT's own lines (FACTS §5): it returns once
    `list` shows the device, after its set-up ended with `established`."""
    world = PortNeeds(hat, _config(), {})
    mark = hat.mark()
    port = world.active(SENSOR[1])
    lines = [e.text for e in hat.since(mark)]
    assert f"P{port}: connecting to active device" in lines
    assert f"P{port}: established serial communication with active ID 3D" in lines
    assert world.settled_entry(port, SENSOR, attempts=1).kind == "active"

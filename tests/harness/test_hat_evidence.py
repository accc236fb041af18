"""harness/hat_evidence.py: what shows a Build HAT that breaks a clause at open (issue 25), and
what does not (silence, garbage, another device's lines, a fault pin's own pace)."""
from __future__ import annotations

from typing import List

import pytest

from buildhat_conformance.harness.events import Event
from buildhat_conformance.harness.hat_evidence import broken_version, power_fault_flood


def test_the_hat_s_own_lines_after_each_crlf_are_a_build_hat() -> None:
    assert "b'\\r\\nError\\r\\n'" in (broken_version(b"\r\nError\r\n" * 3, 3) or "")
    assert broken_version(b"\r\n8.00 V\r\nError\r\n" * 3, 3) is not None


@pytest.mark.parametrize("received", [
    b"",                                            # silence
    b"\r\nERROR\r\n" * 3, b"\r\nOK\r\n" * 3,        # a modem
    b"Error\r\n" * 3,                               # no CRLF for the CR first
    b"\r\nError\r\n" * 2,                           # not every `version` answered
    b"\r\nError\r\n\r\nError\r\n\r\n8.00 V\r\n",    # answers that differ
    b"\r\nError\r\n\r\nError\r\n\r\nError\r\nP",    # anything else besides
    bytes(range(256)) * 3,                          # garbage
])
def test_anything_else_is_not_evidence_of_a_build_hat(received: bytes) -> None:
    assert broken_version(received, 3) is None


START_UP = ["", "Type help <RETURN> for help", "Initialising ports", "Resetting drivers: 0123",
            "Done initialising ports"]


def _events(lines: List[str], faults: int, every_ms: float, first: float = 1600.0) -> List[Event]:
    out = [Event("banner", text, t=1000.0 + i) for i, text in enumerate(lines)]
    return out + [Event("port_fault", "Port power fault", t=first + i * every_ms) for i in range(faults)]


def test_a_start_up_then_a_flood_of_power_faults_breaks_their_pace() -> None:
    finding = power_fault_flood(_events(START_UP, 458, 1.5), reset_ms=1000.0)
    assert finding is not None and "458 within 1500 ms" in finding and "at most 151" in finding


@pytest.mark.parametrize("lines, faults, every_ms", [
    (START_UP, 2, 1000.0),            # a fault pin held low: at once, then 1 Hz
    (START_UP, 90, 11.0),             # a pin that flickers as fast as the deglitch allows
    (START_UP[2:], 458, 1.5),         # no start-up: nothing shows a Build HAT
])
def test_what_a_fault_pin_can_make_or_no_start_up_is_no_finding(lines, faults, every_ms) -> None:
    assert power_fault_flood(_events(lines, faults, every_ms), reset_ms=1000.0) is None


def test_the_window_is_hat_time() -> None:
    # At time scale 10 a session ms is 10 HAT ms: 150 session ms hold the whole 1500 ms window.
    events = _events(START_UP, 200, 0.5, first=1010.0)
    assert power_fault_flood(events, reset_ms=1000.0, time_scale=10.0) is not None
    assert power_fault_flood(events, reset_ms=1000.0, time_scale=10.0, window_ms=100.0) is None

"""The suite's waveform oracle (conformance/oracles/waveform.py) against FIRMWARE-FACTS §7.1."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.oracles.numbers import parse_float
from buildhat_conformance.conformance.oracles.waveform import Generator, ticks_until_done


def number(text: str) -> float:
    """``text`` as the firmware reads it; the examples here are all numbers it accepts."""
    value = parse_float(text)[0]
    assert value is not None, text
    return value


@pytest.mark.parametrize("period,ticks", [(0.1, 11), (0.2, 20), (0.5, 51), (1, 101), (2, 201), (3, 301),
                                          (5, 500), (10, 1000), (0.3, 30), (0.7, 71)])
def test_pulse_end_tick(period: float, ticks: int) -> None:
    assert ticks_until_done(number(str(period))) == ticks


def test_square_starts_at_min_and_ramp_phase() -> None:
    square = [v for v, _ in Generator("square", 0, 1, number("0.2"), 0).run(20)]
    assert square[0] == 0 and square.count(0) in (9, 10, 11) and set(square) == {0, 1}, "starts at min"
    ramp = [v for v, _ in Generator("ramp", 0, 1, 1, 0.5).run(3)]
    assert ramp[0] > 0.5, "the ramp's phase shifts its start"

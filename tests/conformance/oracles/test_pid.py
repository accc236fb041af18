"""The suite's PID model (conformance/oracles/pid.py) against FIRMWARE-FACTS §7.4."""
from __future__ import annotations

from buildhat_conformance.conformance.oracles.floatfmt import fw_float
from buildhat_conformance.conformance.oracles.numbers import parse_float
from buildhat_conformance.conformance.oracles.pid import PidModel, Unwrapper


def number(text: str) -> float:
    """``text`` as the firmware reads it; the examples here are all numbers it accepts."""
    value = parse_float(text)[0]
    assert value is not None, text
    return value


def test_pid_example_sequence_of_facts_7_4() -> None:
    m = PidModel(5, number("0.5"), number("0.1"), 3, number("0.01"))
    got = [" ".join(fw_float(x) for x in m.step(number(pv), 1.0))
           for pv in ("0", "0.1", "0.25", "0.5", "0.995")]
    assert got == ["-1.00000 -0.0100000 -100.000 15.0050", "-0.900000 -0.0190000 10.0000 3.50950",
                   "-0.750000 -0.0265000 15.0000 2.26325", "-0.500000 -0.0315000 25.0000 0.0157499",
                   "0.00000 -0.0315000 50.0000 -4.98425"]


def test_unwrapper_models() -> None:
    r7 = Unwrapper(1, 360, first_sample=True)
    assert [r7.sample(v) for v in (170, -170, 170)] == [170, 190, 170]
    r1 = Unwrapper(1, 360, first_sample=False)
    assert r1.sample(270) == -90, "R1-R5: the first value is the reading folded once from 0"

"""The timing-fidelity measures (bench/fidelity.py), in small and without asserting any timing (a
shared, loaded machine): each measures what it says from the lines the emulator really printed."""
from __future__ import annotations

from buildhat_conformance.bench import fidelity


def test_report_period_measures_the_gaps_between_reports():
    # select 1 reports every 100 ms (docs/FIRMWARE-BEHAVIOUR.md#fb-reporting): 2 s give about 20 gaps.
    got = fidelity.report_period(seconds=2.0)
    assert set(got) == {"mean_ms", "p99_ms", "n"}
    assert 5 <= got["n"] <= 25 and 0 <= got["mean_ms"] <= got["p99_ms"]


def test_pulse_lateness_measures_each_pulse():
    got = fidelity.pulse_lateness(duration_s=0.5, repeats=1)
    assert got["n"] == 1 and got["max_ms"] == got["mean_ms"]

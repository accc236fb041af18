"""The dead-target figure (bench/target_faults.py), in small: a HAT that goes silent at its first `vin`
(tests/faulty/faulty_hat.py) is counted from the run's own JUnit file: the run gives up after five
target faults in a row (README, "Verdicts, target faults and exit statuses": `--max-target-faults`
defaults to 5) and the rest is not run. No timing is asserted."""
from __future__ import annotations

import pytest

from buildhat_conformance.bench import target_faults

pytestmark = pytest.mark.timeout(600)


def test_a_silent_hat_is_given_up_after_five_target_faults():
    got = target_faults.dead_target("silent")
    assert got["faults"] == 5, got
    assert got["note"].startswith("5 target faults, then ") and "cases not run" in got["note"]

"""Which release a fuzz target runs (fuzz/release.py): read from its own `version` answer, and a
target of another known release than --firmware is refused before any budget is spent."""
from __future__ import annotations

import pytest

from buildhat_conformance.emulator.inprocess_target import InProcessTarget
from buildhat_conformance.fuzz.release import ReleaseMismatch, detect_profile, judged_profile


def _opener(firmware: str):
    return lambda: InProcessTarget(firmware=firmware)


@pytest.mark.parametrize("release,number", [("R1", 1630165527), ("R5", 1670596313), ("R7", 1737564117)])
def test_the_release_is_the_one_the_target_names(release, number):
    # fb-releases: the version numbers of R1, R5 and R7.
    profile = detect_profile(_opener(release))
    assert profile.name == release and profile.number == number


def test_a_target_of_another_release_than_asked_is_refused_with_what_to_do():
    with pytest.raises(ReleaseMismatch, match="answers as .*R5.* --firmware R7 .*name R5"):
        judged_profile(_opener("R5"), "R7")
    assert judged_profile(_opener("R5"), "R5").name == "R5"

"""Which release a fuzz target runs (fuzz/running/release.py): read from its own `version` answer, and a
target of another known release than --firmware is refused before any budget is spent."""
from __future__ import annotations

import dataclasses

import pytest

from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.fuzz.running.release import ReleaseMismatch, detect_profile, judged_profile


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


def test_an_emulator_naming_no_release_runs_the_release_the_target_reports():
    # issue #33: `fuzz -t sil:TREE --against emulator` ran the latest release whatever the tree was.
    from buildhat_conformance.fuzz.running.release import against_release
    from buildhat_conformance.protocol.profiles import get_profile
    r5 = get_profile("R5")
    assert against_release("emulator", r5) == (
        "emulator:R5", "--against emulator runs as R5: the release the target reports (1670596313)")
    assert against_release("inprocess", r5)[0] == "inprocess:R5"
    assert against_release("emulator:?speed=10", r5)[0] == "emulator:R5?speed=10"
    for given in ("emulator:R2", "emulator:latest?speed=10", "inprocess:R7", "/dev/serial0", "sil:/tree"):
        assert against_release(given, r5) == (given, None)          # a release it names is kept
    build = dataclasses.replace(get_profile("R7"), version_string="1740000000 2025-02-19T00:00:00+00:00")
    url, said = against_release("emulator", build)
    assert url == "emulator:R7" and said is not None and "nearest earlier" in said and "1740000000" in said


def test_two_different_builds_are_not_compared_on_the_lines_that_name_them():
    from buildhat_conformance.fuzz.oracles.differential import first_difference
    ours = (b"\r\nFirmware version: 1740000000 x\r\n\r\nFirmware signature: 00 11\r\n"
            b"  own help line\r\nError\r\n")
    theirs = (b"\r\nFirmware version: 1737564117 y\r\n\r\nFirmware signature: AA BB\r\n"
              b"  help, ?  : x\r\nError\r\n")
    identity = frozenset({b"  own help line", b"  help, ?  : x"})
    assert first_difference(ours, theirs) is not None              # one build against itself: compared
    assert first_difference(ours, theirs, identity=identity) is None
    assert first_difference(ours, theirs.replace(b"Error", b"8.00 V"), identity=identity) is not None

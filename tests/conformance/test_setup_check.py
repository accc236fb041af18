"""Issue 38: the set-up between cases sees each command's answer. A command the target refuses
is said once, in one line, and the set-up goes on without it; what it resets is reset another way
where the protocol has one; a target refusing the set-up altogether is SetupRefused."""
from __future__ import annotations

from typing import List

import pytest

from buildhat_conformance.conformance.hat_under_test import HatUnderTest
from buildhat_conformance.conformance.setup_check import SetupCheck, SetupRefused
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.protocol.profiles import get_profile

FOUR_MOTORS = "&".join(f"device={p}=0x30" for p in range(4))


def _hat(url: str, judged_as: str) -> HatUnderTest:
    """A HAT whose command set differs from the profile it is judged by (R7 has no `bias`; R5,
    like the 2023-01-26 development build judged as R5, is expected to)."""
    target = make_target(url)
    session = Session(target, profile=get_profile(judged_as))
    session.open()
    return HatUnderTest(session, target, url)


def test_a_refused_set_up_command_is_said_once_and_the_rest_of_the_set_up_still_runs() -> None:
    hat = _hat(f"inprocess:R7?{FOUR_MOTORS}", "R5")
    try:
        hat.resync()
        assert hat.setup_check.said == ["this build has no `bias`: set-up goes on without it"]
        assert hat.setup_said == hat.setup_check.said
        # Port 3 comes after port 0's `bias 0` in the set-up: one long line would stop at the
        # `Error` and leave port 3 reporting.
        hat.exchange("port 3 ; select 1")
        assert hat.expect(lambda e: e.text.startswith("P3M1:"), 500) is not None
        sent = len(hat.session.sent)
        hat.resync()
        hat.resync()
        assert b"bias" not in bytes(hat.session.sent[sent:])     # learnt once: not sent again
        mark = hat.mark()
        hat.wait_ms(300)
        hat.collect_ms(0)
        assert not [e.text for e in hat.since(mark) if e.text.startswith("P3")], "port 3 still reports"
        assert hat.setup_check.said == ["this build has no `bias`: set-up goes on without it"]
        assert hat.setup_check.unreset == []
    finally:
        hat.session.close()


def test_the_set_up_learns_nothing_refused_where_the_profile_is_the_target_s() -> None:
    for release in ("R1", "R5", "R7"):
        hat = _hat(f"inprocess:{release}", release)
        try:
            hat.resync()
            hat.resync()
            assert hat.setup_check.said == [], release
            assert all(hat.setup_check.accepted.values()) and "port" in hat.setup_check.accepted
        finally:
            hat.session.close()


class _Answers:
    """What a target answers each set-up command: `Error` for the refused words."""

    def __init__(self, refused: List[str]):
        self.refused = refused
        self.asked: List[str] = []

    def __call__(self, line: str) -> _Answers:
        self.asked.append(line)
        self.errors = int(line.split()[0] in self.refused)
        return self


SET_UP = ["echo 0", "debug 0", "port 0", "select", "pwm", "off", "bias 0", "port 1", "select", "pwm", "off",
          "bias 0", "port 0"]


def test_a_refused_command_is_replaced_by_one_that_resets_the_same() -> None:
    check = SetupCheck()
    said = check.learn(SET_UP, _Answers(["off"]))
    assert said == ["this build has no `off`: set-up goes on without it (resets with `set 0` instead)"]
    assert check.commands(SET_UP) == [("set 0" if c == "off" else c) for c in SET_UP]
    assert check.unreset == []


def test_what_nothing_else_resets_makes_failures_informational() -> None:
    check = SetupCheck()
    said = check.learn(SET_UP, _Answers(["pwm", "coast"]))
    assert said == ["this build has no `pwm`: set-up goes on without it; the drive mode (PID or direct PWM) "
                    "is not reset between cases: a case that fails is informational"]
    assert check.unreset == ["the drive mode (PID or direct PWM)"]
    assert "pwm" not in check.commands(SET_UP) and "coast" not in check.commands(SET_UP)


@pytest.mark.parametrize("refused", [["port"], [w.split()[0] for w in SET_UP]])
def test_a_target_refusing_its_set_up_altogether_is_set_up_refused(refused: List[str]) -> None:
    with pytest.raises(SetupRefused, match=r"refuses the suite's set-up \(.*`port`.*answer `Error`\)"):
        SetupCheck().learn(SET_UP, _Answers(refused))


def test_an_error_in_a_later_set_up_makes_it_learn_again() -> None:
    check = SetupCheck()
    check.learn(SET_UP, _Answers([]))
    assert not check.due

    class Line:
        def __init__(self, kind: str) -> None:
            self.kind = kind

    assert not check.refusals_seen([Line("banner"), Line("data")])
    assert check.refusals_seen([Line("error")]) and check.due

"""What a wait matches and how a failed wait says what arrived (harness/matching.py)."""
from __future__ import annotations

import re

from buildhat_conformance.harness.events import Event
from buildhat_conformance.harness.matching import describe_events, matcher

PROMPT = Event("prompt", "P0>")
VIN = Event("vin", "7.20 V")


def test_a_kind_a_pattern_and_a_predicate_each_match_and_say_what_they_wait_for():
    pred, what = matcher("prompt")
    assert pred(PROMPT) and not pred(VIN) and what == "an event of kind 'prompt'"
    pred, what = matcher(r"\d\.\d\d V")
    assert pred(VIN) and not pred(PROMPT) and what == r"a line matching /\d\.\d\d V/"
    pred, what = matcher(re.compile("P[0-3]>"))
    assert pred(PROMPT) and what == "a line matching /P[0-3]>/"

    def a_vin_line(e: Event) -> bool:
        """The vin answer."""
        return e.kind == "vin"

    assert matcher(a_vin_line)[1] == "The vin answer"
    assert matcher(lambda e: True)[1] == "a line the caller's condition accepts"


def test_a_failed_wait_says_what_did_arrive():
    assert describe_events([]) == "nothing arrived"
    assert describe_events([], b"P0") == "no complete line arrived, only output not ended by CRLF: b'P0'"
    text = describe_events([VIN] * 30, b"P", limit=2)
    assert text.splitlines()[0] == "30 event(s) arrived, the last 2:" and len(text.splitlines()) == 4
    assert text.endswith("and output not ended by CRLF: b'P'")

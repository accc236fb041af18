"""Failure messages in the suite's voice (conformance/mismatch.py, issue #34): the line sent, what
was expected and what came, at the first line that differs; never pytest's rewriting or advice."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.mismatch import accepted, first_difference, rejected, same
from buildhat_conformance.conformance.reply import Reply

HELP = b"\r\nCommands available:\r\n  version               : print version string\r\n" \
       b"  signature             : dump firmware signature\r\n"


def test_the_first_differing_line_is_named_with_both_sides() -> None:
    changed = HELP.replace(b"signature  ", b"dignature  ")
    assert first_difference(HELP, changed) == (
        "line 4: expected `  signature             : dump firmware signature\\r\\n`, "
        "came `  dignature             : dump firmware signature\\r\\n`")


def test_a_missing_or_extra_line_says_nothing_came_and_counts_both_sides() -> None:
    assert first_difference(b"\r\nError\r\n", b"\r\n") == \
        "line 2 (of 2 expected, 1 came): expected `Error\\r\\n`, came (nothing)"
    assert first_difference(b"\r\n", b"\r\nP0>") == \
        "line 2 (of 1 expected, 2 came): expected (nothing), came `P0>`"


def test_a_reply_that_differs_fails_with_what_was_sent_expected_and_came() -> None:
    reply = Reply(sent=b"?\r", wire=HELP.replace(b"signature  ", b"dignature  "))
    with pytest.raises(AssertionError) as failed:
        same(reply, HELP, "this release's help text (docs/FIRMWARE-BEHAVIOUR.md#fb-help)")
    message = str(failed.value)
    assert message.startswith("sent `?`: expected this release's help text (docs/FIRMWARE-BEHAVIOUR.md"
                              "#fb-help); line 4: expected `  signature")
    assert "came `  dignature" in message and "Use -v" not in message
    same(Reply(sent=b"?\r", wire=HELP), HELP)          # the same bytes: nothing raised


def test_error_and_no_error_are_judged_with_the_line_sent() -> None:
    with pytest.raises(AssertionError, match=r"^sent `vin`: expected `Error` \(docs/FIRMWARE-BEHAVIOUR.md"
                                             r"#fb-errors\); line 2: .*came `8.00 V\\r\\n`"):
        rejected(Reply(sent=b"vin\r", wire=b"\r\n8.00 V\r\n"))
    with pytest.raises(AssertionError, match=r"^sent `set 1e3`: expected no `Error` \(in range\); "
                                             r"came `Error` as line 2 of "):
        accepted(Reply(sent=b"set 1e3\r", wire=b"\r\nError\r\n"), "in range")
    accepted(Reply(sent=b"vin\r", wire=b"\r\n8.00 V\r\n"))
    rejected(Reply(sent=b"vin x\r", wire=b"\r\nError\r\n"))

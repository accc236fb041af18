"""Matching a target's answer against the model's prediction (fuzz/oracles/stream_match.py).

On a paced wire the echo leaves byte by byte as the input arrives, so a data report the HAT
prints meanwhile lands inside the echo; that is timing, not a protocol failure."""
from __future__ import annotations

from buildhat_conformance.fuzz.model.reference_model import ReferenceModel
from buildhat_conformance.fuzz.oracles.stream_match import allowed_kinds, match_stream
from buildhat_conformance.protocol.profiles import get_profile

R7 = get_profile("R7")


def _expected(line: bytes):
    m = ReferenceModel(R7)
    m.feed(b"echo 1\r")
    items, _fates = m.feed(line)
    return items


def test_a_report_cut_into_the_echo_is_skipped_as_asynchronous():
    items = _expected(b"port 2\r")
    whole = b"port 2\r\nP2>"
    assert not match_stream(items, whole, allowed_kinds(R7, 0)).problems
    torn = b"por" + b"P0M1: 5\r\n" + b"t 2\r\nP2>"
    res = match_stream(items, torn, allowed_kinds(R7, 0))
    assert not res.problems, res.problems
    assert [ev.kind for _i, ev in res.asynchronous] == ["mode_data"]
    twice = b"p" + b"P0M1: 5\r\n" + b"P1C0: 1 2\r\n" + b"ort 2\r\nP2>"
    assert not match_stream(items, twice, allowed_kinds(R7, 0)).problems


def test_a_line_that_begins_with_the_echos_next_byte_is_found_where_it_cuts():
    """The sil finding (seed 11): the echo of `...d(` was cut after `...` by `deltat=00000003`, whose
    `d` the echo's next byte matched; the cut is where the whole line starts."""
    items = _expected(b"xd(\r")
    torn = b"x" + b"deltat=00000003\r\n" + b"d(\r\nError\r\nP0>"
    res = match_stream(items, torn, allowed_kinds(R7, 0))
    assert not res.problems, res.problems
    assert [ev.kind for _i, ev in res.asynchronous] == ["deltat"]
    items = _expected(b"xP0\r")                                  # `x` echoed, then `P0M1: 5`, then `P0`
    res = match_stream(items, b"x" + b"P0M1: 5\r\n" + b"P0\r\nError\r\nP0>", allowed_kinds(R7, 0))
    assert not res.problems and [ev.kind for _i, ev in res.asynchronous] == ["mode_data"]
    res = match_stream(items, b"x" + b"P0M1: 5\r\n" + b"P1\r\nError\r\nP0>", allowed_kinds(R7, 0))
    assert res.problems                     # the rest of the echo still has to match


def test_what_cuts_into_the_echo_must_be_an_asynchronous_line():
    items = _expected(b"port 2\r")
    res = match_stream(items, b"por" + b"Error\r\n" + b"t 2\r\nP2>", allowed_kinds(R7, 0))
    assert [p.oracle for p in res.problems] == ["hygiene"], res.problems
    res = match_stream(items, b"por" + b"P0M1: 5\r\n" + b"t 3\r\nP3>", allowed_kinds(R7, 0))
    assert res.problems                     # the rest of the echo still has to match


def test_the_echo_is_made_whole_for_comparison():
    from buildhat_conformance.fuzz.oracles.stream_match import without_torn

    items = _expected(b"port 2\r")
    torn = b"por" + b"P3: D5 signature=0CC0 id=0\r\n" + b"t 2\r\nP2>"
    res = match_stream(items, torn, allowed_kinds(R7, 4))
    assert not res.problems and without_torn(torn, res) == b"port 2\r\nP2>"


def test_a_report_right_after_a_prompt_is_set_apart_for_comparison():
    """On one side a report came between the prompt and the echo of the next line (`P0>P0V: ...`):
    compared without it, the answer is the other side's `P0>version`."""
    from buildhat_conformance.fuzz.model.expect import CRLF_ITEM, exact_item, prompt_item
    from buildhat_conformance.fuzz.oracles.stream_match import allowed_kinds, match_stream, without_torn
    from buildhat_conformance.protocol.profiles import get_profile
    expected = [prompt_item(0), exact_item(b"version", "echo", "state"), CRLF_ITEM]
    got = b"P0>P0V: 0.00000\r\nversion\r\n"
    res = match_stream(expected, got, allowed_kinds(get_profile("R7"), 0))
    assert not res.problems and without_torn(got, res) == b"P0>version\r\n"

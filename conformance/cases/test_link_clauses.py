"""The clauses the harness itself relies on (conformance/trusted_clauses.py), checked first.

The plugin runs these cases before every other one, and tells the link what they found: until a
clause has passed here, the harness's set-up and fences do without it (one command per line, the
counted ``version`` fence); a clause that fails here stays avoided for the rest of the run, and
the summary names it. Each is also an ordinary conformance case of its clause.
"""
from __future__ import annotations

import re

import pytest

from ..hat_under_test import HatUnderTest
from ..target_fault import TargetFault

VIN = re.compile(rb"\r\n[0-9]+\.[0-9]{2} V\r\n")
# `echo 1`, then the fence's `version` echoed after a prompt and answered, then a prompt: a sound
# link, whatever the prompts look like.
ECHO_ON_ANSWERED = re.compile(rb"\r\n(P[^\r\n>]*>)version\r\nFirmware version: [^\r\n]+\r\n(P[^\r\n>]*>)")


def echo_on_reply(hat: HatUnderTest) -> bytes:
    """What `echo 1` printed. A prompt the link does not know as one hides the fence's echo, so
    the link cannot find its place; when the HAT answered that fence whole, the link is sound
    and the prompt is the finding (a garbled link stays a target fault)."""
    start = len(hat.session.received)
    try:
        return hat.exchange("echo 1").raw
    except TargetFault:
        answered = ECHO_ON_ANSWERED.match(bytes(hat.session.received[start:]))
        if answered is None or answered.group(1) == b"P0>":
            raise
        return b"\r\n" + answered.group(1)


@pytest.mark.link_clause("crlf")
@pytest.mark.req("FW-LINE-CR-CRLF", "LINK-TEXT")
def test_clause_cr_ends_a_line_with_crlf(hat: HatUnderTest) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-cr: CR is the only terminator and always gives CRLF, even for an
    # empty line.
    assert hat.exchange("").raw == b"\r\n", \
        "CR/LF clause: an empty line must give exactly CRLF (docs/FIRMWARE-BEHAVIOUR.md#fb-cr)"
    raw = hat.exchange("vin").raw
    assert VIN.fullmatch(raw), f"CR/LF clause: `vin` must give CRLF, then its line ended by CRLF; got {raw!r}"


@pytest.mark.link_clause("version")
@pytest.mark.req("CMD-VERSION")
def test_clause_version_answers_one_line(hat: HatUnderTest) -> None:
    raw = hat.exchange("version").raw
    assert re.fullmatch(rb"\r\nFirmware version: [0-9]+ \S+\r\n", raw), \
        f"version clause: `version` must print one `Firmware version: ` line; got {raw!r}"


@pytest.mark.link_clause("echo")
@pytest.mark.req("CMD-ECHO", "LINK-PROMPT")
def test_clause_echo_on_echoes_and_prompts_echo_off_stops(hat: HatUnderTest) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-echo: `echo 1` typed with echo off gives CRLF and the prompt;
    # then every stored byte is echoed; `echo 0` is echoed (echo was on while it arrived) and prints
    # no prompt.
    on = echo_on_reply(hat)
    typed = hat.exchange("vin").raw
    off = hat.exchange("echo 0").raw
    quiet = hat.exchange("").raw
    assert on == b"\r\nP0>", f"echo clause: `echo 1` must give CRLF and the prompt P0>; got {on!r}"
    assert typed.startswith(b"vin") and VIN.fullmatch(typed[3:-3]) and typed.endswith(b"P0>"), \
        f"echo clause: with echo on `vin` must be echoed, answered and prompted; got {typed!r}"
    assert off == b"echo 0\r\n", f"echo clause: `echo 0` must be echoed and stop the prompt; got {off!r}"
    assert quiet == b"\r\n", f"echo clause: with echo off nothing is echoed and no prompt; got {quiet!r}"


@pytest.mark.link_clause("separator")
@pytest.mark.req("SYN-SEMICOLON")
def test_clause_semicolon_separates_commands(hat: HatUnderTest) -> None:
    one = hat.exchange_quiet("vin").raw
    two = hat.exchange_quiet("vin ; vin").raw
    assert VIN.fullmatch(one), f"`vin` answered {one!r}"
    assert two == one + one[2:], \
        f"separator clause: `vin ; vin` must run both commands (SYN-SEMICOLON); got {two!r}"

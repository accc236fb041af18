"""Link and line handling: plain text, CR as the only terminator, echo and prompt.

Document: LINK-SERIAL, LINK-TEXT, LINK-PROMPT, CMD-ECHO. Firmware facts:
docs/FIRMWARE-BEHAVIOUR.md#fb-line (CR always gives CRLF, LF is an ordinary byte, BS/DEL editing,
256-byte buffer, NUL, `#`).
"""
from __future__ import annotations

import re

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import rejected, same
from ..verdict import Verdict


def vin_line(hat: HatUnderTest) -> bytes:
    """The current ``vin`` answer line, CRLF included (the value depends on the supply)."""
    raw = hat.exchange_quiet("vin").raw
    assert re.fullmatch(rb"\r\n[0-9]+\.[0-9]{2} V\r\n", raw), f"vin answered {raw!r}"
    return raw[2:]


@pytest.mark.req("LINK-SERIAL")
def test_link_carries_clean_text_both_ways(hat: HatUnderTest, verdict: Verdict) -> None:
    # A wrong baud rate, parity or stop bit setting garbles every byte; the version answer
    # arriving byte-exact through this link is what a host can observe of 115200 8N1.
    raw = hat.exchange_quiet("version").raw
    assert re.fullmatch(rb"\r\nFirmware version: [0-9]+ [0-9T:+-]+\r\n", raw), \
        f"sent `version`: expected `Firmware version: <number> <date>` byte for byte, came {raw!r}"
    if not re.match(r"(serial:|/dev/)", hat.url):
        verdict.inform(f"the framing itself (115200 8N1) is not observable through {hat.url}")


@pytest.mark.req("LINK-TEXT")
@pytest.mark.parametrize("command", ["help", "list", "vin", "version", "signature"])
def test_output_is_plain_text_lines(hat: HatUnderTest, command: str) -> None:
    raw = hat.exchange_quiet(command).raw
    text = raw.decode("utf-8")          # raises on anything that is not text
    bad = [c for c in text if ord(c) < 0x20 and c not in "\r\n"]
    assert not bad, f"control characters in the output of {command}: {bad!r}"
    assert raw.endswith(b"\r\n"), f"{command}: output not ended by CRLF: {raw[-20:]!r}"
    assert b"\r\n".join(raw.split(b"\r\n")) == raw and b"\n" not in raw.replace(b"\r\n", b""), \
        f"{command}: a bare CR or LF in the output"


@pytest.mark.req("LINK-PROMPT", "CMD-ECHO", "CMD-PORT")
def test_echo_and_prompt_as_in_appendix_a(hat: HatUnderTest) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-vectors: echo 1 -> CRLF then the prompt; typed text echoed; the
    # prompt shows the port selected at the end of the line; `c` runs clear_faults, which prints
    # nothing.
    same(hat.exchange("echo 1"), b"\r\nP0>")
    same(hat.exchange("p 2"), b"p 2\r\nP2>")
    same(hat.exchange("c"), b"c\r\nP2>")
    assert hat.exchange("echo 0").raw == b"echo 0\r\n", "echo 0 must stop the prompt at once"
    assert hat.exchange("port 0").raw == b"\r\n", "with echo off nothing is echoed and no prompt"


@pytest.mark.req("CMD-ECHO")
def test_echo_defaults_off_and_any_nonzero_enables(hat: HatUnderTest) -> None:
    assert hat.exchange("").raw == b"\r\n", "echo is off by default (only the CRLF every CR gives)"
    assert hat.exchange("echo 5").raw == b"\r\nP0>", \
        "any non-zero value enables echo (docs/FIRMWARE-BEHAVIOUR.md#fb-echo)"
    same(hat.exchange(""), b"\r\nP0>")
    hat.exchange("echo 0")


@pytest.mark.req("FW-LINE-CR-CRLF")
def test_cr_always_answers_crlf(hat: HatUnderTest) -> None:
    line = vin_line(hat)
    same(hat.exchange_quiet("vin"), b"\r\n" + line)
    same(hat.exchange(""), b"\r\n")
    same(hat.exchange(b"\r\r"), b"\r\n\r\n")


@pytest.mark.req("FW-LINE-LF-ORDINARY", "SYN-SEMICOLON")
def test_crlf_from_the_host_breaks_the_next_line(hat: HatUnderTest) -> None:
    # The CRLF pitfall (docs/FIRMWARE-BEHAVIOUR.md#fb-control-bytes, #fb-vectors): LF is stored, so
    # the next line starts with it.
    line = vin_line(hat)
    same(hat.exchange_quiet(b"vin\r\nvin\r"), b"\r\n" + line + b"\r\nError\r\n")
    rejected(hat.exchange(b"vin\n\r"))


@pytest.mark.req("FW-LINE-LF-ORDINARY", "LINK-PROMPT")
def test_crlf_pitfall_with_echo_appendix_a(hat: HatUnderTest) -> None:
    hat.exchange("echo 1")
    raw = hat.exchange(b"port 1\r\nlist\r").raw
    hat.exchange("echo 0 ; port 0")
    same(raw, b"port 1\r\nP1>\nlist\r\nError\r\nP1>",
         "the worked example's answer (docs/FIRMWARE-BEHAVIOUR.md#fb-vectors)", sent=b"port 1\r\nlist")


@pytest.mark.req("FW-LINE-SEPARATORS")
@pytest.mark.parametrize("line", [b"\tvin\r", b"VIN\r", b"Vin\r", b"vin\t\r"])
def test_tab_and_upper_case_are_not_commands(hat: HatUnderTest, line: bytes) -> None:
    rejected(hat.exchange(line))


@pytest.mark.req("FW-LINE-EDITING", "LINK-PROMPT")
@pytest.mark.parametrize("erase", [b"\x08", b"\x7f"])
def test_backspace_and_delete_edit_the_line(hat: HatUnderTest, erase: bytes) -> None:
    line = vin_line(hat)
    hat.exchange("echo 1 ; port 1")
    raw = hat.exchange(b"vinx" + erase + erase + b"\r").raw
    empty = hat.exchange(erase + b"\r").raw
    hat.exchange("echo 0 ; port 0")
    # The echo example of docs/FIRMWARE-BEHAVIOUR.md#fb-echo: the edited line is `vi`, which resolves
    # to vin.
    same(raw, b"vinx\x08 \x08\x08 \x08\r\n" + line + b"P1>", sent=b"vinx" + erase + erase)
    assert empty == b"\r\nP1>", "erasing in an empty buffer echoes nothing"


@pytest.mark.req("FW-LINE-BUFFER")
def test_line_buffer_keeps_the_first_256_bytes(hat: HatUnderTest) -> None:
    line = vin_line(hat)
    body = b"vin" + b" " * 253          # exactly 256 bytes
    assert hat.exchange_quiet(body + b"junk\r").raw == b"\r\n" + line, \
        "bytes after the 256th must be discarded (else `junk` gives Error)"
    hat.exchange("echo 1")
    raw = hat.exchange(body + b"junk\r").raw
    hat.exchange("echo 0")
    assert raw.startswith(body + b"\r\n"), "only the stored 256 bytes are echoed"


@pytest.mark.req("FW-LINE-NUL")
def test_nul_ends_the_line(hat: HatUnderTest) -> None:
    line = vin_line(hat)
    same(hat.exchange_quiet(b"vin\x00junk\r"), b"\r\n" + line)


@pytest.mark.req("FW-HASH-COMMENT")
def test_hash_comment_lines(hat: HatUnderTest) -> None:
    hat.exchange("echo 1")
    comment = hat.exchange("# comment").raw
    spaced = hat.exchange(" # x").raw
    hat.exchange("echo 0")
    if hat.feature("hash_comments"):
        assert comment == b"# comment\r\n", "R6+: ignored, and no prompt follows"
    else:
        same(comment, b"# comment\r\nError\r\nP0>")
    assert spaced == b" # x\r\nError\r\nP0>", "a leading space defeats the comment"

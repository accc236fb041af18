"""Failure messages in the suite's voice: what was sent, what the document or the facts expect,
what came, at the first line that differs.

A case compares a reply with its expectation through :func:`same` (or asserts with a message of
its own), never with a bare ``assert``: `run` gives pytest no ``-v`` to take, and pytest's
rewriting of a bare one ("At index 48 diff: b's' != b'd'") is not a message a HAT's owner can
act on. The suite's child pytest runs with ``--assert=plain`` (conformance/runner.py), and
tests/project/test_case_messages.py keeps every case's asserts carrying their own words.
"""
from __future__ import annotations

from typing import List, Optional, Union

from .reply import Reply

__all__ = ["same", "rejected", "accepted", "first_difference", "shown", "EXPECTED_REPLY", "RECEIVED_REPLY"]

CR = b"\r"
CLIP = 100        # characters of one line a message shows
EXPECTED_REPLY = "expected reply: "     # a failure message's second and third lines: each whole reply
RECEIVED_REPLY = "received reply: "


def shown(line: Optional[bytes]) -> str:
    """One line of a reply as a message shows it: its bytes between backquotes (non-printing
    ones escaped), ``(nothing)`` where the reply had ended."""
    if line is None:
        return "(nothing)"
    text = repr(line)[2:-1]
    return f"`{text if len(text) <= CLIP else text[:CLIP - 1] + '…'}`"


def _lines(data: bytes) -> List[bytes]:
    """``data`` cut after each CRLF; a last piece without one (a prompt) is a line of its own."""
    *ended, rest = data.split(b"\r\n")
    return [line + b"\r\n" for line in ended] + ([rest] if rest else [])


def first_difference(expected: bytes, got: bytes) -> str:
    """Where ``got`` first departs from ``expected``: its line (1-based, counting every CRLF) with
    both sides, e.g. ``line 49: expected `  signature ...\\r\\n`, came `  sXgnature ...\\r\\n```."""
    want, have = _lines(expected), _lines(got)
    for i in range(max(len(want), len(have))):
        a = want[i] if i < len(want) else None
        b = have[i] if i < len(have) else None
        if a != b:
            total = f" (of {len(want)} expected, {len(have)} came)" if len(want) != len(have) else ""
            return f"line {i + 1}{total}: expected {shown(a)}, came {shown(b)}"
    return "the same bytes"


def same(got: Union[Reply, bytes], expected: bytes, what: str = "",
         sent: Union[str, bytes, None] = None) -> None:
    """Fail the case unless ``got`` (a reply, or its ``raw`` bytes) is exactly ``expected``.

    ``what`` names the expectation and where it comes from, e.g. ``"Error (docs/FIRMWARE-
    BEHAVIOUR.md#fb-errors)"``. The message: the line sent, that expectation, the first line that
    differs, both sides. ``sent``: the line sent, where ``got`` is bare bytes."""
    raw = got.raw if isinstance(got, Reply) else got
    if raw == expected:
        return
    line = got.sent if isinstance(got, Reply) else sent.encode() if isinstance(sent, str) else sent
    said = f"sent {shown(line.rstrip(CR))}: " if line is not None else ""
    expect = f"expected {what}; " if what else ""
    # The headline, then both replies whole on lines of their own (REPLY_LINES), which the report
    # reads back to show them side by side (conformance/report/triage.py).
    raise AssertionError(f"{said}{expect}{first_difference(expected, raw)}\n"
                         f"{EXPECTED_REPLY}{expected!r}\n{RECEIVED_REPLY}{raw!r}")


def rejected(got: Union[Reply, bytes]) -> None:
    """Fail the case unless ``got`` is the line's CRLF and `Error` alone: a line the firmware
    rejects (docs/FIRMWARE-BEHAVIOUR.md#fb-errors)."""
    same(got, b"\r\nError\r\n", "`Error` (docs/FIRMWARE-BEHAVIOUR.md#fb-errors)")


def accepted(reply: Reply, what: str = "") -> None:
    """Fail the case if the line printed `Error`: ``what`` says why it must not (a valid command
    of this release, its arguments in range)."""
    if reply.errors == 0:
        return
    where = next((i for i, line in enumerate(reply.lines) if line == "Error"), 0)
    why = f" ({what})" if what else ""
    raise AssertionError(f"sent {shown(reply.sent.rstrip(CR))}: expected no `Error`{why}; came `Error` as "
                         f"line {where + 1} of {shown(reply.raw)}")

"""Whether a target that did not answer ``version`` with a ``Firmware version:`` line still shows
itself to be a Build HAT, one that breaks a clause: ``version`` (CMD-VERSION), or the power-fault
report's pace (PWR-PORT-FAULT) when its flood hides every answer.

Such a HAT deserves a failure of that clause, not a refusal as "not like a Build HAT"; anything
else (silence, garbage, lines that are not the HAT's) stays refused as a target fault. The evidence
is the line discipline and vocabulary the facts give every release (docs/FIRMWARE-BEHAVIOUR.md
#fb-cr): each CR is answered with CRLF before anything else, and then come only lines the Build HAT
prints word for word: ``Error`` (no command matched, #fb-matching) or a ``vin`` line (``7.20 V``, #fb-vin).
A wrong serial device would have to speak exactly that; a modem's ``ERROR`` or ``OK`` does not.

A target that floods instead is reset once (when it can be) and shows the HAT's start-up lines,
``Type help <RETURN> for help`` to ``Done initialising ports`` (docs/FIRMWARE-BEHAVIOUR.md#fb-startup),
then ``Port power fault`` lines faster than any fault pin could make them: the pin must be low for
more than 10 ms before each report, then 1000 ms pass before the next unless it went high and low
again (#fb-power-faults), so a window of D ms holds at most D/10 + 1 of them. A line that arrived
within D ms after the reset was sent within them, whatever the link delayed.
"""
from __future__ import annotations

import re
from typing import Optional, Sequence

from .events import Event

__all__ = ["broken_version", "power_fault_flood", "FLOOD_WINDOW_MS"]

#: A Build HAT line a command can print in place of the version line.
_HAT_LINE = rb"(?:Error|[0-9]+\.[0-9]{2} V)\r\n"
#: One answer: the CR's CRLF, then one or more such lines.
_ANSWER = re.compile(rb"\r\n(?:" + _HAT_LINE + rb")+")


def broken_version(received: bytes, asked: int) -> Optional[str]:
    """One line: what the target printed for ``version`` if all of it (``asked`` answers, each
    its CRLF and the HAT's own lines) shows a Build HAT that breaks CMD-VERSION; else None."""
    answers = []
    at = 0
    while at < len(received):
        match = _ANSWER.match(received, at)
        if match is None:
            return None
        answers.append(match.group(0))
        at = match.end()
    if len(answers) != asked or len(set(answers)) != 1:
        return None      # every `version` answered, and alike: a HAT, not a coincidence
    return (f"`version` must print one `Firmware version: ` line (CMD-VERSION); each of {asked} "
            f"answered {answers[0]!r}, the CRLF and lines a Build HAT prints, but not that one")


FLOOD_WINDOW_MS = 1500.0
_START_UP = ("Type help <RETURN> for help", "Done initialising ports")


def power_fault_flood(events: Sequence[Event], reset_ms: float, window_ms: float = FLOOD_WINDOW_MS,
                      time_scale: float = 1.0) -> Optional[str]:
    """One line if ``events`` (from a reset at ``reset_ms`` on; session ms, ``time_scale`` HAT ms
    each) show the HAT's start-up and more ``Port power fault`` lines within ``window_ms`` of HAT
    time after the reset than a fault pin allows; else None."""
    texts = [e.text for e in events]
    if not all(line in texts for line in _START_UP):
        return None
    count = sum(1 for e in events if e.text == "Port power fault"
                and (e.t - reset_ms) * time_scale <= window_ms)
    allowed = int(window_ms // 10) + 1
    if count <= allowed:
        return None
    return (f"`Port power fault` is printed at once and then every 1000 ms while the fault lasts, each "
            f"after more than 10 ms of fault (PWR-PORT-FAULT); after a reset the HAT printed its start-up "
            f"and then {count} within {window_ms:g} ms, where at most {allowed} fit")

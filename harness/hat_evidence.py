"""Whether a target that did not answer ``version`` with a ``Firmware version:`` line still shows
itself to be a Build HAT, one that breaks the ``version`` clause (CMD-VERSION).

Such a HAT deserves a failure of that clause, not a refusal as "not like a Build HAT"; anything
else (silence, garbage, lines that are not the HAT's) stays refused as a target fault. The evidence
is the line discipline and vocabulary the facts give every release (docs/FIRMWARE-BEHAVIOUR.md
#fb-cr): each CR is answered with CRLF before anything else, and then come only lines the Build HAT
prints word for word: ``Error`` (no command matched, FACTS §2) or a ``vin`` line (``7.20 V``, §4.4).
A wrong serial device would have to speak exactly that; a modem's ``ERROR`` or ``OK`` does not.
"""
from __future__ import annotations

import re
from typing import Optional

__all__ = ["broken_version"]

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

"""What a caller waits for (:data:`Match`) and how a wait that failed says what did arrive."""
from __future__ import annotations

import re
from typing import Callable, List, Pattern, Sequence, Tuple, Union

from .events import KINDS, Event

__all__ = ["Match", "matcher", "describe_events"]

Match = Union[str, Pattern[str], Callable[[Event], bool]]


def matcher(match: Match) -> Tuple[Callable[[Event], bool], str]:
    """(predicate, description). A string naming an event kind matches that kind; any
    other string is a regular expression searched in the line's text. A predicate is
    described by its docstring's first line (a lambda has none: "a line the caller's
    condition accepts", never "<lambda>")."""
    if callable(match) and not isinstance(match, str):
        doc = (getattr(match, "__doc__", None) or "").strip().splitlines()
        name = getattr(match, "__name__", "")
        if doc:
            return match, doc[0].rstrip(".")
        if name and not name.startswith("<"):
            return match, f"a line satisfying {name}"
        return match, "a line the caller's condition accepts"
    if isinstance(match, str) and match in KINDS:
        return (lambda e: e.kind == match), f"an event of kind {match!r}"
    rx = re.compile(match) if isinstance(match, str) else match
    return (lambda e: bool(rx.search(e.text))), f"a line matching /{rx.pattern}/"


def describe_events(events: Sequence[Event], partial: bytes = b"", limit: int = 25) -> str:
    """What arrived, for error messages: the last ``limit`` events and any partial line."""
    if not events and not partial:
        return "nothing arrived"
    if not events:
        return f"no complete line arrived, only output not ended by CRLF: {partial[-200:]!r}"
    shown = list(events[-limit:])
    tail = f", the last {len(shown)}:" if len(shown) < len(events) else ":"
    lines: List[str] = [f"{len(events)} event(s) arrived{tail}"]
    lines += [f"  {e}" for e in shown]
    if partial:
        lines.append(f"  and output not ended by CRLF: {partial[-200:]!r}")
    return "\n".join(lines)

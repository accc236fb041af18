"""The part of a transcript around a failure, as text lines a person can read.

A failing case's transcript usually ends where the test stopped, so by default the excerpt
is its tail; a ``t`` (ms) given by the case centres it instead.
"""
from __future__ import annotations

from typing import List, Optional, Union

from ...harness.transcript import field_bytes, iter_events

__all__ = ["excerpt_lines", "format_event"]


def format_event(ev: dict) -> Optional[str]:
    """One readable line per event: ``>`` host bytes, ``<`` HAT line, ``~`` partial, ``*`` other."""
    kind = ev.get("dir")
    t = ev.get("t", "")
    stamp = f"{float(t):>10.1f} ms" if isinstance(t, (int, float)) else f"{'':>13}"
    if kind == "host":
        return f"{stamp}  > {field_bytes(ev, 'bytes')!r}"
    if kind == "hat":
        if "line" in ev:
            return f"{stamp}  < {_printable(ev['line'])}"
        return f"{stamp}  ~ {_printable(ev.get('partial', ''))}"
    if kind in ("dev", "devrx"):
        return f"{stamp}  * {kind} P{ev.get('port')} {ev.get('hex', '')}"
    if kind in ("pwm", "led"):
        port = f" P{ev['port']}" if "port" in ev else ""
        return f"{stamp}  * {kind}{port} {ev.get('value')}"
    if kind == "note":
        return f"{stamp}  # {ev.get('text', '')}"
    if kind == "end":
        return f"{stamp}  (end)"
    return None


def _printable(text: str) -> str:
    return "".join(c if c.isprintable() or c == " " else f"\\x{ord(c):02X}" for c in text)


def _compress(events: List[dict], keep: int = 2) -> List[Union[str, dict]]:
    """Runs of more than ``keep`` + 1 asynchronous lines (data streams, debug 16, in any mix)
    become their first ``keep`` lines and a count per class, so the commands stay in view."""
    from ...transcripts.compare import ASYNC_CLASSES, default_classifier

    classify = default_classifier()
    out: List[Union[str, dict]] = []   # events, and one summary line per compressed run
    run: List[dict] = []
    kinds: List[str] = []

    def flush() -> None:
        if len(run) > keep + 1:
            out.extend(run[:keep])
            rest = kinds[keep:]
            counts = ", ".join(f"{k} ×{rest.count(k)}" for k in dict.fromkeys(rest))
            out.append(f"{'':>13}  … {len(rest)} more line(s): {counts}")
        else:
            out.extend(run)
        run.clear()
        kinds.clear()

    for e in events:
        cls = classify(e["line"]) if e.get("dir") == "hat" and "line" in e else None
        if cls in ASYNC_CLASSES:
            run.append(e)
            kinds.append(str(cls))
            continue
        flush()
        out.append(e)
    flush()
    return out


def excerpt_lines(path: str, around_t: Optional[float] = None, before: int = 25, after: int = 8,
                  kinds: tuple = ("host", "hat", "note", "end")) -> List[str]:
    """Lines around ``around_t`` (or the last ``before`` lines); device and drive events are
    left out unless asked for, since a failure on the command port is read on the command port.
    Long runs of data or debug lines are shortened to a count."""
    events = [e for e in iter_events(path) if e.get("dir") in kinds]
    items = _compress(events)
    if around_t is None:
        chosen = items[-before:]
    else:
        idx = next((i for i, e in enumerate(items)
                    if isinstance(e, dict) and float(e.get("t", 0)) >= around_t), len(items))
        chosen = items[max(0, idx - before):idx + after]
    shown = (e if isinstance(e, str) else format_event(e) for e in chosen if isinstance(e, (str, dict)))
    lines = [s for s in shown if s is not None]
    if len(chosen) < len(items):
        lines.insert(0, f"{'':>13}  … {len(items) - len(chosen)} earlier/later item(s) not shown")
    return lines

"""Read a transcript file a user gave, and say where it is wrong: ``FILE:LINE: what``.

:func:`harness.transcript.read_transcript` reads what our own tools wrote; a file from
elsewhere (hand-edited, from another tool, cut short) is checked here first against
docs/formats/TRANSCRIPT.md, so a bad field is reported with its file and line instead of
surfacing later as ``could not convert string to float: 'x'``.
"""
from __future__ import annotations

import json
import os
from typing import Union

from ..harness.transcript import Transcript, read_transcript
from ..plumbing.cli_options import UsageError

__all__ = ["load_transcript", "check_event"]

_TEXT = {"host": ("bytes",), "hat": ("line", "partial"), "note": ("text",)}


def check_event(obj: object, first: bool) -> str:
    """What is wrong with one decoded line ("" if nothing)."""
    if not isinstance(obj, dict):
        return f"an event is a JSON object, got {type(obj).__name__}"
    kind = obj.get("dir")
    if first:
        return "" if kind == "meta" else 'the first line must be the {"dir":"meta",...} object'
    if not isinstance(kind, str):
        return f"'dir' must be a string, got {kind!r}"
    if kind == "meta":
        return "a second meta line"
    t = obj.get("t")
    if kind != "end" or "t" in obj:
        if isinstance(t, bool) or not isinstance(t, (int, float)):
            return f"'t' must be a number of milliseconds, got {t!r}"
    fields = _TEXT.get(kind)
    if fields:
        present = [f for f in fields if f in obj]
        if not present:
            return f"a {kind!r} event needs {' or '.join(repr(f) for f in fields)}"
        if not isinstance(obj[present[0]], str):
            return f"{present[0]!r} must be a string, got {obj[present[0]]!r}"
    if "hex" in obj:
        try:
            bytes.fromhex(str(obj["hex"]))
        except ValueError:
            return f"'hex' is not hexadecimal bytes: {obj['hex']!r}"
    return ""


def load_transcript(path: Union[str, os.PathLike]) -> Transcript:
    """The transcript in ``path``; UsageError naming the file (and line) for anything wrong.
    A truncated last line (the writer was killed) is skipped, as the reader does."""
    name = os.fspath(path)
    try:
        with open(name, encoding="utf-8") as fh:
            lines = fh.readlines()
    except FileNotFoundError:
        raise UsageError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise UsageError(f"{name}: is a directory, not a transcript") from None
    except UnicodeDecodeError as exc:
        raise UsageError(f"{name}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise UsageError(f"{name}: cannot read: {exc.strerror}") from None
    first = True
    for n, raw in enumerate(lines, 1):
        if not raw.strip():
            continue
        try:
            obj = json.loads(raw)
        except json.JSONDecodeError as exc:
            if n == len(lines) and not first:
                break
            raise UsageError(f"{name}:{n}: not JSON ({exc.msg}): {raw.strip()[:60]!r}") from None
        problem = check_event(obj, first)
        if problem:
            raise UsageError(f"{name}:{n}: {problem}")
        first = False
    if first:
        raise UsageError(f"{name}: empty, not a transcript")
    try:
        return read_transcript(name)
    except ValueError as exc:
        raise UsageError(f"{name}: {exc}") from None

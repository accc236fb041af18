"""A finding in the user's terms: which line of which step went wrong, and the first line that
differs (expected vs got, or one target vs the other). The runner puts these in the finding's
message (its terminal line) and details (the script's header comment)."""
from __future__ import annotations

import os
from typing import Dict, List, Optional, Sequence

from ..model.expect import Expect

__all__ = ["sent_lines", "line_index", "expected_line", "got_line", "shown", "stream_details"]

_SHOW = 160          # bytes of a step or line shown in a one-line message


def shown(data: Optional[bytes], limit: int = _SHOW) -> str:
    if data is None:
        return "nothing"
    return repr(data[:limit]) + (f"... ({len(data)} bytes)" if len(data) > limit else "")


def sent_lines(blob: bytes) -> List[bytes]:
    """The step's bytes cut after every CR: one entry per line the HAT processed."""
    out, start = [], 0
    while True:
        end = blob.find(b"\r", start)
        if end < 0:
            break
        out.append(blob[start:end + 1])
        start = end + 1
    if start < len(blob):
        out.append(blob[start:])
    return out


def line_index(expected: Sequence[Expect], idx: int) -> int:
    """Which CR-terminated line produced ``expected[idx]``: every CR prints its CRLF first
    (fb-cr), so the CRLFs before the item count the lines ended; an echo belongs to the next one."""
    crs = sum(1 for it in expected[:idx] if it.what == "CRLF after CR")
    if idx >= len(expected):
        return max(crs - 1, 0)
    item = expected[idx]
    if item.what == "echo":
        return crs
    if item.what == "CRLF after CR":
        # Where the next line's CRLF was due, what came instead is still the answer to the line
        # before (an extra line), unless this line's echo came first.
        after_echo = idx > 0 and expected[idx - 1].what == "echo"
        return crs if after_echo or crs == 0 else crs - 1
    return max(crs - 1, 0)


def _rendered(item: Expect) -> bytes:
    if item.kind == "exact":
        return item.data
    if item.kind == "pattern":
        return f"<{item.what} /{item.pattern}/>\r\n".encode()
    return b"<list dump of ports 0..3>\r\n"


def expected_line(expected: Sequence[Expect], idx: int, into: int = 0) -> Optional[bytes]:
    """The predicted line that byte ``into`` of the item at ``idx`` falls in (None: nothing
    more was predicted)."""
    if idx >= len(expected):
        return None
    rendered = _rendered(expected[idx])
    before = b"".join(_rendered(it) for it in expected[:idx]) + rendered[:into]
    rest = rendered[into:] + b"".join(_rendered(it) for it in expected[idx + 1:])
    start = before.rfind(b"\r\n")
    head = before[start + 2:] if start >= 0 else before
    end = rest.find(b"\r\n")
    return head + (rest if end < 0 else rest[:end])


def got_line(actual: bytes, pos: int) -> Optional[bytes]:
    """The received line ``pos`` falls in (None: nothing more arrived)."""
    if pos >= len(actual):
        return None
    start = actual.rfind(b"\r\n", 0, pos)
    start = 0 if start < 0 else start + 2
    end = actual.find(b"\r\n", pos)
    return actual[start:] if end < 0 else actual[start:end]


def stream_details(blob: bytes, expected: Sequence[Expect], actual: bytes, idx: int, pos: int) -> Dict:
    """``line``, ``expected_line`` and ``got_line`` of a mismatch at item ``idx``, byte ``pos``."""
    lines = sent_lines(blob)
    k = line_index(expected, idx)
    item = expected[idx] if idx < len(expected) else None
    # Inside a long exact item (the help text) the first differing byte is what counts.
    into = 0
    if item is not None and item.kind == "exact":
        into = len(os.path.commonprefix([item.data, actual[pos:pos + len(item.data)]]))
    more: Dict[str, object] = {"line": lines[k] if k < len(lines) else None,
                               "expected_line": expected_line(expected, idx, into),
                               "got_line": got_line(actual, pos + into)}
    if item is not None and item.what == "CRLF after CR" and not more["expected_line"]:
        nxt = line_index(expected, idx) + (0 if idx and expected[idx - 1].what == "echo" else 1)
        if nxt < len(lines) and nxt != k:
            more["expected_note"] = f"the CRLF that the CR of {shown(lines[nxt])} prints first"
    return more


def _step(blob: bytes, line: Optional[bytes]) -> str:
    if line is not None and line != blob:
        return f"line {shown(line)} of step {shown(blob)}"
    return f"step {shown(blob)}"


def stream_message(label: str, problem_message: str, at: Optional[tuple], blob: bytes,
                   expected: Sequence[Expect], actual: bytes) -> tuple:
    """(message, details) for an answer that does not match the model's prediction."""
    if at is None:                    # an asynchronous line the state does not allow
        return f"{label}: {_step(blob, None)}: {problem_message}", {}
    more = stream_details(blob, expected, actual, *at)
    exp, got = more["expected_line"], more["got_line"]
    note = f" ({more['expected_note']})" if "expected_note" in more else ""
    message = (f"{label}: {_step(blob, more['line'])}: first differing line: expected "
               f"{shown(exp) if exp is not None else 'no more output'}{note}, got {shown(got)} "
               f"[{problem_message[:_SHOW + 40]}{'...' if len(problem_message) > _SHOW + 40 else ''}]")
    return message, more


def liveness_message(label: str, reason: str, blob: bytes, fence_line: bytes, received: bytes) -> tuple:
    """(message, details) for a step whose fence did not answer."""
    lines = [x for x in received.split(b"\r\n") if x]
    last = lines[-1] if lines else None
    more = {"expected_line": fence_line.rstrip(b"\r\n"), "got_line": last}
    return (f"{label}: {_step(blob, None)}: {reason}; expected the fence's line "
            f"{shown(more['expected_line'])}, the last line that came was {shown(last)}", more)


def differential_message(labels: Sequence[str], blob: bytes, piece: int, a: Optional[bytes],
                         b: Optional[bytes]) -> tuple:
    """(message, details) for two targets that answered one step differently."""
    more = {f"{labels[0]}_line": a, f"{labels[1]}_line": b}
    return (f"{_step(blob, None)}: first differing line (answer line {piece + 1}): {labels[0]} printed "
            f"{shown(a)}, {labels[1]} printed {shown(b)}", more)


def header_lines(details: Dict, labels: Sequence[str] = ("target", "against")) -> List[str]:
    """The same facts for the script's header comment: the step, its line, the differing lines."""
    out = []
    step = details.get("step")
    if isinstance(step, (bytes, str)):
        out.append(f"step sent: {shown(step if isinstance(step, bytes) else step.encode(), 600)}")
    if details.get("line") is not None:
        out.append(f"line: {shown(details['line'], 600)}")
    if "expected_line" in details:
        exp = details["expected_line"]
        note = f" ({details['expected_note']})" if "expected_note" in details else ""
        out.append(f"expected line: {shown(exp, 600) if exp is not None else 'no more output'}{note}")
        out.append(f"got line: {shown(details.get('got_line'), 600)}")
    for label in labels:
        if f"{label}_line" in details:
            out.append(f"{label} printed: {shown(details[f'{label}_line'], 600)}")
    return out

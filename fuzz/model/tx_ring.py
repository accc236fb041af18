"""The HAT's TX ring, as far as the fuzzer must know it (docs/FIRMWARE-BEHAVIOUR.md#fb-tx-ring,
#fb-reporting, #fb-debug).

Output leaves through an 8192-byte ring at the wire's pace (11.52 bytes/ms at 115200 baud); an
output byte written while the ring is full is dropped, silently. Data reports are held back
(not dropped) while the ring holds 4096 bytes or more, so reports alone keep at most that much
(and one report line) queued; the `debug` streams of DATA payloads (8) and PID lines (16) are
not held back and can fill the ring. Hence, on a wire:

- a step whose predicted output is longer than what the ring has room for (8192 less what the
  streams may hold) may come back with bytes missing, but never among the first bytes of its
  output (they always fit): :func:`headroom` says whether a step is at risk and from where;
- the fence must not be sent into a full ring (its answer would be lost): the runner lets the
  step's output drain first (:func:`drain_ms`), and appends `debug 0` to a line that would leave
  an unheld debug stream running (as it does for the raw serial trace of bit 1);
- such a step is judged by :func:`fuzz.lossymatch.match_lossy`: what came must be the predicted
  answer with bytes missing only past the headroom, whole asynchronous lines between, and the
  fence's answer whole.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

from .port_model import PortModel

__all__ = ["RING_SIZE", "THROTTLE", "UNHELD_DEBUG", "WIRE_BYTES_PER_MS", "backlog", "headroom", "drain_ms",
           "input_ms"]

RING_SIZE = 8192            # fb-tx-ring
THROTTLE = 4096             # fb-reporting-r5: no report is printed while the ring holds this much
REPORT_LINE_MAX = 256       # a report line (held back as a whole, never cut) is shorter than this
FENCE_ROOM = 128            # the fence's answer (CRLF, the version line, a prompt) fits in this
WIRE_BYTES_PER_MS = 11.52   # 115200 baud, 8N1 (fb-uart)
UNHELD_DEBUG = 8 | 16      # DATA payloads and PID lines: printed whatever the ring holds (fb-debug)


def backlog(states: Sequence[Sequence[PortModel]], debug: int, selrate_engine: bool, throttle: bool) -> int:
    """The most the ring may hold, from what streams, when the step's output starts (its answer
    waits behind that on the wire). ``debug``: the bits set before or after the step;
    ``throttle``: the release holds reports back at 4096 bytes (R5+, fb-reporting-r5). Without it (R1-R4) a
    port reports at most every 100 ms (fb-reporting-r1), less than the wire carries: a line per port."""
    if debug & UNHELD_DEBUG:
        return RING_SIZE
    # A port whose state the model lost (a link change) may still report if a mode is selected.
    streaming = any(p.reporting(selrate_engine) or (not p.known and p.mode >= 0)
                    for ports in states for p in ports)
    if not streaming:
        return 0
    return THROTTLE + REPORT_LINE_MAX if throttle else 4 * REPORT_LINE_MAX


def headroom(queued: int, size: int) -> Optional[int]:
    """The bytes of a step's output that always fit in the ring, when ``size`` (its predicted
    output, the most it may be) may not, with ``queued`` (:func:`backlog`) ahead; None when all fits."""
    room = RING_SIZE - queued
    return room if size > room else None


def drain_ms(size: int, sent: int, keep: int) -> int:
    """HAT ms to wait before the fence of a step that sends ``sent`` bytes and may print ``size``
    into a ring with room for ``keep``: its input must arrive, and enough must leave that the
    fence's answer fits (what reports add meanwhile is held back at 4096 bytes). A fifth more,
    and 10 ms, for a target that runs a little slower than the wire."""
    must_leave = max(0, size + FENCE_ROOM - keep)
    return math.ceil((sent + must_leave) / WIRE_BYTES_PER_MS * 1.2) + 10


# A line that has arrived is read and answered within a main-loop pass; a pass over 2 ms prints
# a stall line (fb-stall), a long `list` makes one of about 3 ms.
PASS_MARGIN_MS = 5


def input_ms(sent: int) -> int:
    """HAT ms before a pause may end early (``TargetExchange.settle``, fuzz/running/target_exchange.py):
    the ``sent`` bytes have crossed the wire and the last line has been read and begun answering."""
    return math.ceil(sent / WIRE_BYTES_PER_MS) + PASS_MARGIN_MS

"""The real-time loop: wall clock -> emulator ticks, host bytes in and out, control requests.

Host input is handed to the firmware as soon as it arrives (the HAT's main loop is far
faster than 1 kHz); ticks are run in small batches from the drift-free clock, and between
batches the loop sleeps in select(), so an idle emulator costs little CPU.
"""
from __future__ import annotations

import select
import sys
from typing import Any, Callable, Optional

from .clock import RealTimeClock

__all__ = ["run_realtime", "BATCH_SECONDS", "MAX_TICKS_PER_PASS"]

# Wake at least this often (wall seconds) to run the ticks that came due. One millisecond, so
# that at speed 1 every tick's output leaves when it is made: with 4 ms a report was held back
# for up to 4 ms and its period error was 1.5 ms on average (H10 bench: 0.7 ms now); the cost
# is about 4 % more of a core for an idle emulator.
BATCH_SECONDS = 0.001
# At most this many ticks between two looks at the host's input. When the machine cannot keep
# up with the speed (a loaded machine, a high --speed), the backlog is worked off in slices
# so that a command still gets its answer within a few milliseconds (H10: the catch-up of
# up to 2000 ticks in one go delayed answers by ~100 ms).
MAX_TICKS_PER_PASS = 100


def run_realtime(emulator: Any, link: Any, clock: RealTimeClock, control: Any = None, lint: Any = None,
                 should_stop: Optional[Callable[[], bool]] = None) -> int:
    """Run until the host side ends (stdio EOF), ``should_stop()`` is true, or a strict lint fails.
    Returns the process exit status."""
    while True:
        due = min(clock.due(), MAX_TICKS_PER_PASS)
        for _ in range(due):
            emulator.step()
        clock.done(due)
        if lint is not None:
            lint.follow(emulator)
        out = emulator.read()
        if out:
            link.send(out)
        if lint is not None and getattr(lint, "strict", False):
            message = lint.fatal_message()
            if message:
                link.flush()
                print(message, file=sys.stderr, flush=True)
                return 3
        if should_stop is not None and should_stop():
            return 0
        readables = list(link.readables()) + (control.sockets() if control is not None else [])
        timeout = 0.0 if clock.due() else max(clock.seconds_until_next(), BATCH_SECONDS)
        try:
            ready, writable, _ = select.select(readables, link.writables(), [], timeout)
        except InterruptedError:
            continue
        if writable:
            link.flush()
        for obj in ready:
            if control is not None and obj in control.sockets():
                control.handle([obj])
                continue
            try:
                data = link.on_readable(obj)
            except EOFError:            # stdin closed: the host has gone
                return 0
            if data:
                if lint is not None:
                    lint.feed_input(data)
                emulator.write(data)
                out = emulator.read()
                if out:
                    link.send(out)

"""The real-time loop: wall clock -> emulator ticks, host bytes in and out, control requests.

Host input is handed to the firmware as soon as it arrives (the HAT's main loop is far
faster than 1 kHz), after *every* tick that came due: the firmware sees a line at the virtual
millisecond it arrived, never earlier, so what the line starts (a `set pulse`, a report period)
is timed from its arrival on the host's clock too (issue 27). Ticks are run in small batches
from the drift-free clock, and between batches the loop sleeps in select() until the next tick
that can do anything (``Emulator.idle_until``), so an idle emulator costs little CPU.
"""
from __future__ import annotations

import select
import sys
from typing import Any, Callable, Optional

from .clock import RealTimeClock

__all__ = ["run_realtime", "BATCH_SECONDS", "MAX_TICKS_PER_PASS", "MAX_SLEEP_SECONDS", "MAX_LAG_MS"]

# Sleep at least this long (wall seconds) between batches of ticks, unless a backlog of
# MAX_TICKS_PER_PASS is waiting. One millisecond, so that at speed 1 every tick's output leaves
# when it is made: with 4 ms a report was held back for up to 4 ms and its period error was
# 1.5 ms on average (H10 bench: 0.7 ms). Ticks in which nothing is due are not waited for: the
# loop sleeps until the next one that can do something (10 ms at most, the controllers'), as a
# wake-up costs ~50 us of CPU on a virtual machine.
BATCH_SECONDS = 0.001
# ... and at most this long, so that ``should_stop`` is asked often enough at low speeds.
MAX_SLEEP_SECONDS = 0.05
# At most this many ticks between two looks at the host's input while nothing arrives. When the
# machine cannot keep up with the speed (a loaded machine, a high --speed), the backlog is worked
# off in slices, so input and control requests are noticed within a few milliseconds.
MAX_TICKS_PER_PASS = 100
# When input does arrive, the whole backlog is run first (_catch_up): handing the line over while
# the HAT's clock lags would stamp it that much early, and the catch-up after it would then run
# what the line started (a 5 s pulse) faster than the host's clock (issue 27). The answer waits for
# the catch-up instead (H10: ~100 ms for 2000 ticks), as a HAT's answer would wait for a stalled
# main loop. A lag longer than this is a stopped process (SIGSTOP, a debugger): the rest is lost
# time, skipped, so the HAT runs that much behind from then on; late, never early.
MAX_LAG_MS = 2000
_READ_ANY = 65536     # bytes read from the link at once when the wire is not paced


def _run_due(emulator: Any, clock: RealTimeClock) -> None:
    """Run the ticks that came due (at most MAX_TICKS_PER_PASS); idle ones cost next to nothing."""
    due = min(clock.due(), MAX_TICKS_PER_PASS)
    if due:
        emulator.advance(due)
        clock.done(due)


def _catch_up(emulator: Any, clock: RealTimeClock) -> None:
    """Run every tick due by now (at most MAX_LAG_MS; a longer lag is skipped), so that what is
    handed over next happens at the virtual millisecond it arrived."""
    ran = 0
    while ran < MAX_LAG_MS:
        due = min(clock.due(), MAX_LAG_MS - ran)
        if not due:
            return
        emulator.advance(due)
        clock.done(due)
        ran += due
    late = clock.behind()
    if late:
        clock.skip(late)


def _sleep_seconds(emulator: Any, clock: RealTimeClock) -> float:
    """How long select() may wait: until the next tick that can do anything is due."""
    due = clock.due()
    if due >= MAX_TICKS_PER_PASS:
        return 0.0                  # behind: keep working the backlog off, slice by slice
    ahead = emulator.idle_until() - emulator.now     # >= 1: ticks until one that does something
    wait = clock.seconds_until(ahead) if due < ahead else 0.0
    return min(max(wait, BATCH_SECONDS), MAX_SLEEP_SECONDS)


def run_realtime(emulator: Any, link: Any, clock: RealTimeClock, control: Any = None, lint: Any = None,
                 should_stop: Optional[Callable[[], bool]] = None, tap: Any = None) -> int:
    """Run until the host side ends (stdio EOF), ``should_stop()`` is true, or a strict lint fails.
    ``tap`` (optional) sees every byte: ``tap.host(data)`` as it is read, ``tap.hat(data)`` as it is sent.
    With a baud rate no more host bytes are read than the wire carries (``Emulator.host_room``), so the
    link pushes back on the host. Returns the process exit status."""

    def send_output() -> None:
        out = emulator.read()
        if out:
            if tap is not None:
                tap.hat(out)
            link.send(out)

    while True:
        _run_due(emulator, clock)
        if lint is not None:
            lint.follow(emulator)
        send_output()
        if lint is not None and getattr(lint, "strict", False):
            message = lint.fatal_message()
            if message:
                link.flush()
                print(message, file=sys.stderr, flush=True)
                return 3
        if should_stop is not None and should_stop():
            return 0
        room = emulator.host_room()
        readables = list(link.readables(data=room != 0))
        readables += control.sockets() if control is not None else []
        writables = list(link.writables()) + (control.writables() if control is not None else [])
        try:
            ready, writable, _ = select.select(readables, writables, [], _sleep_seconds(emulator, clock))
        except InterruptedError:
            continue
        if writable:
            if control is not None:
                control.flush(writable)
            link.flush()
        for obj in ready:
            # The loop may have slept through idle ticks, or lag behind on a loaded machine:
            # run them all, so that what arrives is handled at the virtual time it arrives.
            _catch_up(emulator, clock)
            if control is not None and obj in control.sockets():
                control.handle([obj])
                continue
            room = emulator.host_room()
            try:
                data = link.on_readable(obj, _READ_ANY if room is None else room)
            except EOFError:            # stdin closed: the host has gone
                return 0
            if data:
                if tap is not None:
                    tap.host(data)
                if lint is not None:
                    lint.feed_input(data)
                emulator.write(data)
                send_output()

"""Data reporting of one port: select / selonce / selrate / combi state and the data lines
(FIRMWARE-BEHAVIOUR.md#fb-data-lines, #fb-reporting).

Two engines, chosen by ``Profile.features["report_engine"]``:

- ``fixed_100ms`` (R1-R4): every select/selonce re-sends SELECT; reports every 100 ms counted
  from the first matching DATA message, the timer advanced by subtracting the period (no
  drift); ``selonce`` clears the selection after its report, except in the variable form when
  ``selonce_var_repeats`` (the firmware bug: it keeps reporting).
- ``selrate`` (R5+): rate -2 off, -1 once, 0 every message, N every N ms (timer reset to 0 at
  each report); SELECT only when the mode changes; ``combi`` deselects; once = immediately on
  the first matching message, then rate -2 with the mode kept; no report while the TX ring
  holds 4096 bytes or more (``tx_throttle_reports``). The per-pass check is #fb-reporting-r5's, in its
  order: no mode -> nothing (the timer runs on); no matching message since the select or the
  last direct (rate 0) report -> timer held at 0; throttle; -2; -1; 0 (report, clear the
  count); N (report when the timer reaches N, timer 0). So ``selrate 0`` reports the stored
  data on the next pass, and ``selrate N`` after a direct report counts from the next message.

Common: nothing prints until a DATA message for the selected mode arrived after the select;
reports use the latest stored payload; DATA messages carry a 3-bit mode, so a selected mode
8..15 never matches.
"""
from __future__ import annotations

import math
import struct
from typing import Dict, List, Optional, Protocol, Tuple

from ..commands.parser import format_is_float, format_is_signed, format_size
from ..commands.printers import format_float, format_int
from ..devices.info import FORMAT_SIZES, DeviceInfo
from ..services import PortServices, Wakeable

__all__ = ["Reporter", "FIXED_PERIOD_MS", "DEFAULT_RATE_MS", "TX_THROTTLE_BYTES", "RATE_OFF",
           "RATE_ONCE", "MAX_RATE_MS", "read_value", "decode_values"]

FIXED_PERIOD_MS = 100        # R1-R4 report period
DEFAULT_RATE_MS = 100        # R5+ DEFAULT_SELREPRATE, set by every `select`
TX_THROTTLE_BYTES = 4096
RATE_OFF, RATE_ONCE = -2, -1
MAX_RATE_MS = 1000000000


def read_value(buf: bytes, offset: int, fmt: int) -> float:
    """The variable form's value: ``fmt`` (parser format code) at ``offset``, little-endian."""
    size = format_size(fmt)
    raw = bytes((buf[offset:offset + size] + bytes(size))[:size])
    if format_is_float(fmt):
        return struct.unpack("<f", raw)[0]
    return float(int.from_bytes(raw, "little", signed=format_is_signed(fmt)))


def _int_at(buf: bytes, pos: int, ftype: int) -> tuple[str, int]:
    size = FORMAT_SIZES.get(ftype, 1)
    raw = bytes((buf[pos:pos + size] + bytes(size))[:size])
    if ftype == 3:
        return format_float(struct.unpack("<f", raw)[0]), size
    return format_int(int.from_bytes(raw, "little", signed=True)), size


def decode_values(buf: bytes, length: int, count: int, ftype: int) -> List[str]:
    """Mode line values: min(count, whole values in the received length), each printed."""
    size = FORMAT_SIZES.get(ftype, 1)
    n = min(count, length // size)
    return [_int_at(buf, i * size, ftype)[0] for i in range(n)]


class ReporterPort(Wakeable, Protocol):
    """A port as its ``Reporter`` sees it."""

    @property
    def hat(self) -> PortServices: ...

    @property
    def index(self) -> int: ...

    @property
    def info(self) -> Optional[DeviceInfo]: ...

    @property
    def combis(self) -> Dict[int, List[Tuple[int, int]]]: ...

    def send_select(self, mode: int) -> None: ...

    def stored(self, mode: int) -> Tuple[bytes, int]: ...


class Reporter:
    """The select state and report timer of one port."""

    def __init__(self, port: ReporterPort):
        self.port = port
        features = port.hat.profile.features
        self.fixed = features["report_engine"] == "fixed_100ms"
        self.resend_always = features["select_resend"] == "always"
        self.combi_deselects = bool(features["combi_clears_selection"])
        self.var_once_repeats = bool(features["selonce_var_repeats"])
        self.once_keeps_mode = features["once_end_state"] == "rate_off_mode_kept"
        self.throttle = bool(features["tx_throttle_reports"])
        self.mode = -1
        self.offset = 0
        self.fmt: Optional[int] = None     # parser format code of the variable form
        self.rate = RATE_OFF               # R5+ selreprate
        self.once = False                  # R1-R4 selonce flag
        self._seen = 0                     # matching DATA messages since the select (R5+: or
        #                                    since the last direct report: `selrxcount`)
        self._due: Optional[int] = None    # R1-R4: when the next report is due
        self._origin = port.hat.now        # R5+: the report timer is `now - _origin`

    # -- commands --------------------------------------------------------------------------
    # Each command changes what the report engine does next: the port must tick again (wake).
    def select(self, mode: int, offset: Optional[int] = None, fmt: Optional[int] = None,
               once: bool = False) -> None:
        """``select``/``selonce`` with a mode (and the variable form's offset and format)."""
        send = self.resend_always or mode != self.mode
        self.mode = mode
        if offset is not None:
            self.offset = offset
        self.fmt = fmt
        self.once = once
        self.rate = RATE_ONCE if once else DEFAULT_RATE_MS
        self._seen = 0
        self._due = None
        self.port.wake()
        if send:
            self.port.send_select(mode)

    def deselect(self) -> None:
        """``select`` with no argument: stop reporting, send nothing."""
        self.mode = -1
        self.rate = RATE_OFF
        self.port.wake()

    def bad_format(self, offset: int) -> None:
        """``select <m> <off>`` with a bad or missing format: reporting off, offset kept."""
        self.offset = offset
        self.mode = -1
        self.rate = RATE_OFF
        self.port.wake()

    def set_rate(self, ms: int) -> None:
        """``selrate`` (R5+): only the rate changes (clamped to 0..1e9)."""
        self.rate = max(0, min(MAX_RATE_MS, ms))
        self.port.wake()

    def combi_changed(self) -> None:
        """A ``combi`` message was sent (R5+ drops the selection so the next select re-sends)."""
        if self.combi_deselects:
            self.mode = -1
        self.port.wake()

    def connection_changed(self) -> None:
        """Connect, disconnect or timeout. The R5+ engine resets the select state (#fb-active,
        #fb-reporting-r5).
        The R1-R4 engine keeps the selection; since the port's stored data is cleared with a new
        connection, the report waits for fresh data of that mode (a modelling choice: the facts
        do not say what R1-R4 print from the previous device's data)."""
        if not self.fixed:
            self.mode = -1
            self.rate = RATE_OFF
        self._seen = 0
        self._due = None
        self._origin = self.port.hat.now     # the firmware zeroes the report timer (state 105)

    # -- data ------------------------------------------------------------------------------
    def on_data(self, mode: int) -> None:
        """A DATA message for (3-bit) ``mode`` was stored."""
        if mode == self.mode:
            if self._seen == 0:
                # Every pass before this one held the timer at 0 (no message yet).
                self._origin = self.port.hat.now
            self._seen += 1

    def next_due(self, now: int) -> float:
        """The first millisecond after ``now`` in which :meth:`tick` can print or change state
        without a new DATA message (messages arrive on port ticks of their own)."""
        if self.mode < 0 or self._seen == 0:
            return math.inf
        if self.fixed:
            return now + 1 if self._due is None else self._due
        if self.rate == RATE_OFF:
            return math.inf
        if self.rate in (RATE_ONCE, 0):
            return now + 1                 # a message is waiting to be reported
        return self._origin + self.rate    # when past (throttled): every millisecond

    def tick(self, now: int) -> None:
        if self.mode < 0:
            return                         # R5+: the timer runs on
        if self._seen == 0:
            self._origin = now             # R5+: timer held at 0 until a message arrives
            return
        if self.fixed:
            self._tick_fixed(now)
        else:
            self._tick_rate(now)

    def _tick_fixed(self, now: int) -> None:
        if self._due is None:
            self._due = now + FIXED_PERIOD_MS
            return
        if now < self._due:
            return
        self._due += FIXED_PERIOD_MS          # subtractive: no drift
        mode_form = self.fmt is None
        self._print()
        if self.once and (mode_form or not self.var_once_repeats):
            self.mode = -1

    def _tick_rate(self, now: int) -> None:
        if self.throttle and self.port.hat.tx_pending() >= TX_THROTTLE_BYTES:
            return
        if self.rate == RATE_OFF:
            return
        if self.rate == RATE_ONCE:
            self._print()
            self.rate = RATE_OFF
            if not self.once_keeps_mode:
                self.mode = -1
            return
        if self.rate == 0:
            self._print()
            self._seen = 0                 # the next direct report needs a new message
            return
        # The timer counts from the first matching message, then from each report (the
        # firmware resets it to 0), so ``selrate`` changes only the threshold.
        if now - self._origin >= self.rate:
            self._print()
            self._origin = now

    # -- output ----------------------------------------------------------------------------
    def _print(self) -> None:
        self.port.hat.emit(self.report_line())

    def report_line(self) -> str:
        """The line for the current selection from the latest stored payload (#fb-data-lines)."""
        port = self.port
        p = f"P{port.index:X}"
        buf, length = port.stored(self.mode)
        if self.fmt is not None:
            return f"{p}V: {format_float(read_value(buf, self.offset, self.fmt))}"
        combi = port.combis.get(self.mode)
        if combi:
            values = []
            pos = 0
            for mode, _dataset in combi:          # datasets are not used when decoding
                info = port.info.modes.get(mode) if port.info else None
                text, size = _int_at(buf, pos, info.type if info else 0)
                values.append(text)
                pos += size
            return f"{p}C{self.mode}:" + "".join(" " + v for v in values)
        info = port.info.modes.get(self.mode) if port.info else None
        values = decode_values(buf, length, info.count, info.type) if info else []
        return f"{p}M{self.mode}:" + "".join(" " + v for v in values)

"""Power faults (FIRMWARE-BEHAVIOUR.md#fb-power-faults, #fb-timing): the port-supply and motor-driver
fault pins.

``Hat`` builds ``FaultMonitor(hat)`` and calls ``tick(now)`` every millisecond.

- ``Port power fault``: the 3.3 V supply fault pin. Printed once the pin has been low for more
  than 10 ms, then every 1000 ms while it stays low; it stops when the pin goes high.
- ``Motor power fault``: the drivers' fault output. A fault is *latched in the driver* (with its
  flag bytes, registers 0x4D-0x4F) until ``clear_faults`` runs with the cause removed; the pin is
  low while any driver holds a latch, and a latched driver's output is off.
  The report per release comes from ``Profile.features["motor_fault_report"]``:
  ``"text_1hz"`` (R1: as the port fault) or ``"dump_holdoff"`` (R2+: after more than 10 ms low
  the text and the 5-line register dump, then a 1000 ms hold-off in which the pin is not
  looked at, then again more than 10 ms low: a period of about 1011 ms).

World actions (scenario scripts, the control channel; parsed by ``transcripts.script`` and routed
by ``emulator/world_actions.py``) land here: ``@portfault 1|0`` -> :meth:`FaultMonitor.port_fault`;
``@motorfault 1 P [F4D F4E F4F]`` / ``@motorfault 0 [P]`` -> :meth:`FaultMonitor.motor_fault`.
The ``clear_faults`` command calls :meth:`FaultMonitor.clear_faults`.
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

from .services import FaultServices

__all__ = ["FaultCauses", "FaultMonitor", "DEGLITCH_MS", "REPEAT_MS", "HOLDOFF_MS", "DEFAULT_FLAGS",
           "motor_fault_cause"]

DEGLITCH_MS = 10          # the pin must be low for *more* than this
REPEAT_MS = 1000          # port fault (and R1 motor fault) repeat period
HOLDOFF_MS = 1000         # R2+ motor fault: the pin is not examined for this long
DEFAULT_FLAGS = (0x01, 0x00, 0x00)
NPORTS = 4


class _RepeatingReport:
    """'Low for more than 10 ms, then every 1000 ms while low' (port fault, R1 motor fault)."""

    def __init__(self) -> None:
        self.low_since: Optional[int] = None
        self.next_at: Optional[int] = None

    def due(self, low: bool, now: int) -> bool:
        if not low:
            self.low_since = self.next_at = None
            return False
        if self.low_since is None:
            self.low_since = now
        if self.next_at is None:
            # The firmware counts the whole ms since the last tick that saw the pin high: the
            # tick before the first that sees it low (fb-power-faults, "more than 10 ms").
            if now - (self.low_since - 1) > DEGLITCH_MS:
                self.next_at = now + REPEAT_MS
                return True
            return False
        if now >= self.next_at:
            self.next_at += REPEAT_MS      # drift-free, like the firmware's timer
            return True
        return False


class _HoldoffReport:
    """R2+ motor fault: low for more than 10 ms -> report, then 1000 ms without looking."""

    def __init__(self) -> None:
        self.low_since: Optional[int] = None
        self.holdoff_until: Optional[int] = None

    def due(self, low: bool, now: int) -> bool:
        if self.holdoff_until is not None:
            if now < self.holdoff_until:
                return False
            self.holdoff_until = None
        if not low:
            self.low_since = None
            return False
        if self.low_since is None:
            self.low_since = now
        if now - self.low_since > DEGLITCH_MS:
            self.low_since = None
            self.holdoff_until = now + HOLDOFF_MS
            return True
        return False


class FaultCauses:
    """The world's side of the fault pins: ``@portfault`` and ``@motorfault`` set the causes and
    latch a driver's flags. The emulator's monitor and sil's world (sil/port_world.py) share it; each
    says in :meth:`_fault_changed` what a change sets going."""

    def __init__(self) -> None:
        self.port_fault_low = False
        # ``@portfault 1 MS``: the pulse's length, until its owner, which knows the HAT's time,
        # turns it into ``port_fault_until`` (the HAT ms at which the pin goes high again).
        self.port_fault_pulse: Optional[int] = None
        self.port_fault_until: Optional[float] = None
        self.cause: List[bool] = [False] * NPORTS          # world: the fault condition exists
        self.latched: List[Optional[tuple]] = [None] * NPORTS   # driver latch: flag bytes

    def _fault_changed(self, ports: Sequence[int]) -> None:
        raise NotImplementedError

    def port_fault(self, asserted: bool, ms: Optional[int] = None) -> None:
        """``@portfault 1|0``: the 3.3 V port supply fault pin low (1) or high (0);
        ``@portfault 1 MS``: low for MS ms of HAT time, then high again, timed by the HAT's
        clock (a host's wall clock cannot time the deglitch boundary, fb-power-faults)."""
        self.port_fault_low = bool(asserted)
        self.port_fault_pulse = int(ms) if asserted and ms is not None else None
        self.port_fault_until = None
        self._fault_changed(())

    def _start_pulse(self, now: float) -> None:
        """A pulse asked for in the world action starts at the HAT's ``now``."""
        if self.port_fault_pulse is not None:
            self.port_fault_until = now + self.port_fault_pulse
            self.port_fault_pulse = None

    def _pulse_over(self, now: float) -> bool:
        """True (once) when a pulse's time is up: the pin is high again from ``now``."""
        if self.port_fault_until is None or now < self.port_fault_until:
            return False
        self.port_fault_low, self.port_fault_until = False, None
        return True

    def motor_fault(self, asserted: bool, port: Optional[int] = None,
                    flags: Optional[Sequence[int]] = None) -> None:
        """``@motorfault 1 P [F4D F4E F4F]`` asserts the fault of port P's driver and latches
        ``flags``; ``@motorfault 0 [P]`` removes the cause on P (all ports without P). The
        latch stays until the firmware clears it."""
        if asserted:
            p, latched = motor_fault_cause(port, flags)
            self.latched[p] = latched
            self.cause[p] = True
            self._fault_changed((p,))
        else:
            for p in range(NPORTS) if port is None else (_check_port(port),):
                self.cause[p] = False
            self._fault_changed(())


class FaultMonitor(FaultCauses):
    """Fault pins, driver latches and the messages they cause."""

    def __init__(self, hat: FaultServices) -> None:
        super().__init__()
        self.hat = hat          # the HAT as far as the fault monitor may use it
        style = hat.profile.features["motor_fault_report"]
        if style not in ("text_1hz", "dump_holdoff"):
            raise ValueError(f"unknown motor_fault_report {style!r}")
        self.dump_registers = style == "dump_holdoff"
        self._port_report = _RepeatingReport()
        self._motor_report = _HoldoffReport() if self.dump_registers else _RepeatingReport()
        self.due: float = 0     # the Hat ticks the monitor from this virtual ms on

    def _wake(self, ports: Sequence[int] = ()) -> None:
        """A pin or latch changed: tick again from the next ms; a latch change also changes
        what the motors on ``ports`` see (:meth:`output_disabled`)."""
        self.due = 0
        self.hat.wake()
        for p in ports:
            self.hat.ports[p].wake()

    # -- world actions (FaultCauses) -------------------------------------------------------
    def _fault_changed(self, ports: Sequence[int]) -> None:
        # The action comes between the ticks ``now`` and ``now + 1``: a pulse is seen low by
        # the ticks now+1 .. now+MS, as the firmware sees a pulse that starts mid-millisecond.
        self._start_pulse(self.hat.now + 1)
        self._wake(ports)

    # -- firmware side -------------------------------------------------------------------
    def clear_faults(self) -> None:
        """``clear_faults``: every driver whose fault cause is gone drops its latch."""
        for p in range(NPORTS):
            if not self.cause[p]:
                self.latched[p] = None
        self._wake(range(NPORTS))

    def output_disabled(self, port: int) -> bool:
        """True while port's driver holds a latched fault (its output is off)."""
        return self.latched[port] is not None

    @property
    def motor_fault_low(self) -> bool:
        return any(f is not None for f in self.latched)

    def tick(self, now: int) -> None:
        """One millisecond of the main loop's global fault processing."""
        self._tick(now)
        # Quiet (see _quiet): nothing to do until a world action or clear_faults wakes it.
        self.due = math.inf if self._quiet() else now + 1

    def _tick(self, now: int) -> None:
        self._pulse_over(now)
        if self._quiet():
            return      # H10: nothing low, nothing latched, no report armed: due() would not change
        if self._port_report.due(self.port_fault_low, now):
            self.hat.emit(b"Port power fault")
        if self._motor_report.due(self.motor_fault_low, now):
            self.hat.emit(b"Motor power fault")
            if self.dump_registers:
                for line in self.register_dump():
                    self.hat.emit(line.encode("ascii"))

    def _quiet(self) -> bool:
        # With the pins high both reports only clear low_since/next_at (and a hold-off that
        # is over is cleared as well when a pin next goes low), so when those are already
        # clear a tick has no effect: skipping it saves a tenth of an idle tick.
        port, motor = self._port_report, self._motor_report
        return (not self.port_fault_low and self.latched.count(None) == NPORTS
                and port.low_since is None and port.next_at is None and motor.low_since is None
                and getattr(motor, "next_at", None) is None)

    def register_dump(self) -> List[str]:
        """The 5-line dump of registers 0x4D-0x4F of the 4 drivers (R2+)."""
        lines = [" Port 4D 4E 4F"]
        for p in range(NPORTS):
            flags = self.latched[p] or (0, 0, 0)
            lines.append(f"   {p} " + "".join(f" {b:02X}" for b in flags))
        return lines

    # -- helpers -------------------------------------------------------------------------
    @staticmethod
    def _check_port(port: int) -> int:
        return _check_port(port)


def _check_port(port: int) -> int:
    if not 0 <= int(port) < NPORTS:
        raise ValueError(f"port must be 0..{NPORTS - 1}, got {port}")
    return int(port)


def motor_fault_cause(port: Optional[int], flags: Optional[Sequence[int]]) -> Tuple[int, Tuple[int, ...]]:
    """The port and the three latched bytes of ``@motorfault 1 P [F4D F4E F4F]``, checked
    (ValueError); the emulator's fault monitor and sil's world (sil/port_world.py) read it alike."""
    if port is None:
        raise ValueError("@motorfault 1 needs a port: @motorfault 1 P [F4D F4E F4F]")
    p = _check_port(port)
    flags = DEFAULT_FLAGS if flags is None else tuple(flags)
    if len(flags) != 3 or any(not 0 <= int(f) <= 0xFF for f in flags):
        raise ValueError(f"motor fault flags must be 3 bytes 00..FF, got {list(flags)}")
    return p, tuple(int(f) for f in flags)

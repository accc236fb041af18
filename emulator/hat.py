"""``Hat``: one running firmware instance (one release profile) in virtual time.

The Hat owns the command port (UART rings, line editor, dispatcher, start-up) and the
global state the commands of FIRMWARE-BEHAVIOUR.md#fb-commands set and read (current port, echo, debug,
LED mode, input voltage).
Ports, controllers and the fault monitor are separate objects it ticks:

- ``emulator/ports/port.py``      ``Port(hat, index)``           with ``tick(now)``
- ``emulator/motor/controller.py`` ``PortController(hat, index)`` with ``tick(now)``
- ``emulator/power_faults.py``     ``FaultMonitor(hat)``          with ``tick(now)``

The Hat is their composition root: it builds them and hands each itself, which each part sees
only through its Protocol in ``emulator/services.py`` (``PortServices``, ``ControllerServices``,
``FaultServices``, ``StartupServices``; the commands: ``emulator/commands/context.py``). No part
imports this module (tests/emulator/test_layering.py).

Each of them keeps ``due``: the first virtual millisecond in which its tick may do anything
(0: at once). The Hat ticks an object only from then on, and a millisecond in which nothing is
due (the usual case: timers run every 5-100 ms) costs a counter increment; :meth:`Hat.advance`
jumps over a run of them. What changes an object's state from outside its own tick wakes it
(``wake()``: due 0), so the output and events are the same as ticking everything every ms.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional

from ..protocol.pass_cost import PassCost, stall_line
from ..protocol.profiles import Profile, get_profile
from .command_uart import Uart
from .commands.dispatch import run_line
from .commands.line_editor import CRLF, LineEditor
from .motor.controller import PortController
from .ports.port import Port
from .power_faults import FaultMonitor
from .startup import Startup

__all__ = ["Hat", "LineRecord", "DEFAULT_ADC", "NPORTS"]

NPORTS = 4
DEFAULT_ADC = 1742  # SCENARIO-SCRIPT `@adc` default: 8.00 V
PORTS_START_MS = 1  # docs/EMULATOR-MODELS.md "Start-up timeline"
_HASH = 0x23


@dataclass
class LineRecord:
    """What one processed command line did (handed to ``hat.line_observers``)."""

    raw: bytes                 # the line as stored by the editor (no CR)
    now: int                   # virtual ms when it was processed
    ready: bool                # False if its bytes arrived before the start-up finished
    error: bool                # the line printed ``Error``
    commands: List[str] = field(default_factory=list)  # command names that ran (in order)
    unknown: List[str] = field(default_factory=list)   # tokens that matched no command
    comment: bool = False      # a ``#`` line ignored by R6+


def led_code_for_vin(mv: int) -> int:
    """ledmode -1 (#fb-ledmode): the LED code that follows the input voltage."""
    if mv < 4800:
        return 0
    if mv < 6000:
        return 3
    if mv < 8500:
        return 2
    return 1


EventSink = Callable[[str, int, Dict[str, Any]], None]


class Hat:
    """The firmware. ``tick()`` advances one millisecond; ``poll()`` handles received input now."""

    def __init__(self, profile: Optional[Profile] = None, uart: Optional[Uart] = None, *,
                 version_string: Optional[str] = None, signature: Optional[bytes] = None,
                 event_sink: Optional[EventSink] = None, now: int = 0, seed: int = 0,
                 fast_setup: bool = False):
        self.profile = profile if profile is not None else get_profile()
        self.uart = uart if uart is not None else Uart()
        self.now: int = now
        self.seed = seed
        # Devices set up at the profile's faster rate, not the port's 2400 baud (only when asked).
        self.fast_setup = fast_setup
        self.version_string = version_string or self.profile.version_string
        # The signature shown by `signature`: the uploaded one, else the release's (None: unknown).
        self.signature = signature if signature is not None else self.profile.signature
        self.event_sink = event_sink
        self.port = 0
        self.echo = 0
        self.debug = 0
        self.ledmode = -1
        self.adc = DEFAULT_ADC           # the firmware's sample of the input-voltage pin
        self._adc_pin = DEFAULT_ADC      # the pin itself (`@adc`); sampled every 1 ms tick
        self.leds = 0
        self._led_mode: Any = None       # ledmode and adc the LED code was last computed from
        self._led_adc: Any = None
        self.drive: List[Any] = [0] * NPORTS
        self.line_observers: List[Callable[[LineRecord], None]] = []
        # A bound method, not a lambda: copy.deepcopy (the inprocess target copies a booted
        # HAT) re-binds methods to the copy but keeps a lambda pointing at the original.
        self.editor = LineEditor(self.write_out, self.echo_enabled)
        self._early_bytes = 0    # bytes received before the main loop started, not yet consumed
        # Main-loop stalls (#fb-stall): a line whose pass costs >= 1 ms keeps the loop busy
        # until ``_busy_until``; the pass that starts then prints the stall line if > 2 ms.
        self.pass_cost = PassCost(self.profile.features)
        self.tx_written = 0      # bytes the firmware has written to the TX ring (costs lines)
        self._busy_until = 0
        self._stall_ms = 0
        self._line_early = False
        self.ports = [Port(self, i) for i in range(NPORTS)]
        self.controllers = [PortController(self, i) for i in range(NPORTS)]
        self.faults = FaultMonitor(self)
        self.startup = Startup(self)
        self._next_due: float = 0       # min of the ports', controllers' and monitor's ``due``

    # -- state -----------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        """True once ``Done initialising ports`` was printed and the main loop runs."""
        return self.startup.done

    @property
    def vin_mv(self) -> int:
        """Input voltage in mV from the ADC reading, integer steps as in #fb-vin."""
        return ((self.adc * 57) // 10) * 3300 // 4096

    def set_adc(self, raw: int) -> None:
        """The input-voltage pin now reads ``raw``; the firmware samples it on its next 1 ms
        tick (#fb-vin, #fb-timing), so a `vin` in the same millisecond still shows the previous sample."""
        if not 0 <= raw <= 4095:
            raise ValueError(f"ADC reading must be 0..4095, got {raw}")
        self._adc_pin = raw

    @property
    def busy(self) -> bool:
        """True while a stalled main-loop pass runs (nothing else of the loop happens)."""
        return self._busy_until > self.now

    # -- output ----------------------------------------------------------------------------
    def echo_enabled(self) -> bool:
        return bool(self.echo)

    def write_out(self, data: bytes) -> None:
        """Raw output (echo, prompts, partial lines) into the TX ring."""
        self.tx_written += len(data)
        self.uart.write(bytes(data))

    def emit(self, line: bytes | str) -> None:
        """One output line; CRLF is added."""
        if isinstance(line, str):
            line = line.encode("utf-8")
        self.tx_written += len(line) + 2
        self.uart.write(bytes(line) + CRLF)

    def tx_pending(self) -> int:
        """Bytes queued in the TX ring (R5+ report throttle, #fb-reporting-r5)."""
        return self.uart.tx_pending()

    def event(self, kind: str, **fields: Any) -> None:
        """A transcript event (``dev``, ``devrx``, ``pwm``, ``led``, ``note``) at the current time."""
        if self.event_sink is not None:
            self.event_sink(kind, self.now, fields)

    def note(self, text: str) -> None:
        self.event("note", text=text)

    def set_drive(self, port: int, duty: Any) -> None:
        """The motor driver of ``port`` now outputs ``duty`` (±255 or "coast"); events on change."""
        if self.drive[port] != duty:
            self.drive[port] = duty
            self.event("pwm", port=port, value=duty)

    # -- time ------------------------------------------------------------------------------
    def wake(self) -> None:
        """A port, controller or the fault monitor is due earlier than the Hat last noted."""
        self._next_due = 0

    def tick(self) -> None:
        """One millisecond: wire, LEDs, start-up or main loop (input, ports, controllers, faults);
        what it wrote starts to leave on a paced wire in the same millisecond."""
        uart = self.uart
        if uart.baud is None:
            self._tick()
            return
        uart.tick_out(0.5)
        self._tick()
        uart.tick_in()
        uart.tick_out(0.5)

    def _tick(self) -> None:
        now = self.now = self.now + 1
        uart = self.uart
        self.adc = self._adc_pin                 # the 1 ms ADC sample (#fb-timing)
        if self.ledmode != self._led_mode or self.adc != self._led_adc:
            self._refresh_leds()
        startup = self.startup
        if not startup.done:
            startup.tick()
            if startup.done:
                self._early_bytes = uart.rx_available()
                for port in self.ports:
                    # The ports' state machines start in the next millisecond (the firmware in
                    # the loop, its stand-in's idle skip off: docs/EMULATOR-MODELS.md "Start-up timeline").
                    port.due = now + PORTS_START_MS
                for controller in self.controllers:
                    controller.start(now)
            return
        if self._busy_until:
            if now < self._busy_until:
                return                           # the stalled pass is still running
            self._end_stall()
        if uart.rx:
            self.poll()
            if self._busy_until:
                return                           # a line stalled the loop: the rest waits
        if now >= self._next_due:
            self._run_due(now)

    def _end_stall(self) -> None:
        """The first pass after a stall: the firmware prints ``deltat=`` when it was > 2 ms."""
        deltat, self._busy_until, self._stall_ms = self._stall_ms, 0, 0
        if self.pass_cost.prints_stall(deltat):
            self.emit(stall_line(deltat))

    def _run_due(self, now: int) -> None:
        """Tick what is due (in the firmware's order), then note when the next thing is."""
        for port in self.ports:
            if now >= port.due:
                port.tick(now)
        for controller in self.controllers:
            if now >= controller.due:
                controller.tick(now)
        faults = self.faults
        if now >= faults.due:
            faults.tick(now)
        # After all of them: a controller may have woken a port it already passed.
        nxt = faults.due
        for obj in self.ports:
            if obj.due < nxt:
                nxt = obj.due
        for obj in self.controllers:
            if obj.due < nxt:
                nxt = obj.due
        self._next_due = nxt

    def idle_until(self) -> float:
        """The first millisecond whose tick may do anything; every tick before it only counts
        time. ``now + 1`` while anything else is pending (start-up, input, the paced wire, LEDs)."""
        if (not self.uart.quiet() or self.ledmode != self._led_mode or self.adc != self._led_adc
                or self._adc_pin != self.adc):
            return self.now + 1
        if self._busy_until:
            return max(self._busy_until, self.now + 1)
        if not self.startup.done or self.uart.rx:
            return self.now + 1
        return max(self._next_due, self.now + 1)

    def advance(self, ms: int) -> None:
        """``ms`` ticks, jumping over the milliseconds in which nothing is due."""
        end = self.now + ms
        while self.now < end:
            nxt = self.idle_until()
            if nxt > self.now + 1:
                # Those ticks would only have counted. nxt < end here is a finite due time,
                # a whole ms (``due`` is float only to hold math.inf).
                self.now = int(min(nxt, end)) - 1
            self.tick()

    def poll(self) -> None:
        """Process the received bytes now (the main loop runs far faster than 1 kHz)."""
        if not self.startup.done or self._busy_until:
            return
        rx = self.uart.rx
        if not rx:
            return
        # Everything received is taken at once and handed to the editor a line at a time
        # (H10: byte-at-a-time calls dominated the cost of a line). Nothing reads the ring
        # while a line runs; if a line raises, the bytes not yet taken go back.
        data = bytes(rx)
        rx.clear()
        pos = 0
        try:
            while pos < len(data):
                nxt, line = self.editor.feed_run(data, pos)
                if self._early_bytes:
                    self._early_bytes -= min(self._early_bytes, nxt - pos)
                    self._line_early = True
                pos = nxt
                if line is not None:
                    early, self._line_early = self._line_early, False
                    self.process_line(line, ready=not early)
                    # Commands mostly wake what they change (reporter, device frames), but may
                    # also write port state directly: every port looks again (costs one tick).
                    for port in self.ports:
                        port.wake()
                    if self._busy_until:
                        break            # the stalled pass: the next line waits for its end
        finally:
            if pos < len(data):
                rx.extendleft(reversed(data[pos:]))

    def _charge(self, commands: List[str], written: int) -> None:
        """The pass that ran this line lasts its cost (#fb-stall): a stall of whole milliseconds."""
        cost_us = self.pass_cost.line_cost_us(commands, written, self.ports)
        stall = int(cost_us // 1000)
        if stall >= 1:
            self._stall_ms = stall
            self._busy_until = self.now + stall

    def _refresh_leds(self) -> None:
        # tick() calls this only when ledmode or the ADC reading changed (H10: it ran every ms).
        self._led_mode, self._led_adc = self.ledmode, self.adc
        code = led_code_for_vin(self.vin_mv) if self.ledmode < 0 else self.ledmode & 3
        if code != self.leds:
            self.leds = code
            self.event("led", value=code)

    # -- lines -----------------------------------------------------------------------------
    def process_line(self, line: bytes, ready: bool = True) -> LineRecord:
        """Run one finished line (after its CRLF was sent): comment, commands, prompt, observers."""
        record = LineRecord(raw=line, now=self.now, ready=ready, error=False)
        if line[:1] == bytes((_HASH,)) and self.profile.features.get("hash_comments"):
            record.comment = True        # R6+: ignored, and no prompt either
        else:
            written = self.tx_written
            record.error, record.commands, record.unknown = run_line(self, line)
            if self.echo:
                self.write_out(b"P%d>" % self.port)
            self._charge(record.commands, self.tx_written - written)
        for observer in list(self.line_observers):
            observer(record)
        return record

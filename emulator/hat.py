"""``Hat``: one running firmware instance (one release profile) in virtual time.

The Hat owns the command port (UART rings, line editor, dispatcher, start-up) and the
global state of FIRMWARE-FACTS §4 (current port, echo, debug, LED mode, input voltage).
Ports, controllers and the fault monitor are separate objects it ticks:

- ``emulator/ports.py``      ``Port(hat, index)``           with ``tick(now)``
- ``emulator/controller.py`` ``PortController(hat, index)`` with ``tick(now)``
- ``emulator/faults.py``     ``FaultMonitor(hat)``          with ``tick(now)``

"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional

from buildhat_conformance.protocol.profiles import Profile, get_profile

from .commands import run_line
from .controller import PortController
from .faults import FaultMonitor
from .lineeditor import CRLF, LineEditor
from .ports import Port
from .startup import Startup
from .uart import Uart

__all__ = ["Hat", "LineRecord", "DEFAULT_ADC", "NPORTS"]

NPORTS = 4
DEFAULT_ADC = 1742  # SCENARIO-SCRIPT `@adc` default: 8.00 V
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
    """ledmode -1 (§4.1): the LED code that follows the input voltage."""
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
                 event_sink: Optional[EventSink] = None, now: int = 0, seed: int = 0):
        self.profile = profile if profile is not None else get_profile()
        self.uart = uart if uart is not None else Uart()
        self.now = now
        self.seed = seed
        self.version_string = version_string or self.profile.version_string
        # The signature shown by `signature`: the uploaded one, else the release's (None: unknown).
        self.signature = signature if signature is not None else self.profile.signature
        self.event_sink = event_sink
        self.port = 0
        self.echo = 0
        self.debug = 0
        self.ledmode = -1
        self.adc = DEFAULT_ADC
        self.leds = 0
        self._led_key: Any = None        # (ledmode, adc) the LED code was last computed from
        self.drive: List[Any] = [0] * NPORTS
        self.line_observers: List[Callable[[LineRecord], None]] = []
        # A bound method, not a lambda: copy.deepcopy (the inprocess target copies a booted
        # HAT) re-binds methods to the copy but keeps a lambda pointing at the original.
        self.editor = LineEditor(self.write_out, self.echo_enabled)
        self._early_bytes = 0    # bytes received before the main loop started, not yet consumed
        self._line_early = False
        self.ports = [Port(self, i) for i in range(NPORTS)]
        self.controllers = [PortController(self, i) for i in range(NPORTS)]
        self.faults = FaultMonitor(self)
        self.startup = Startup(self)

    # -- state -----------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        """True once ``Done initialising ports`` was printed and the main loop runs."""
        return self.startup.done

    @property
    def vin_mv(self) -> int:
        """Input voltage in mV from the ADC reading, integer steps as in §4.4."""
        return ((self.adc * 57) // 10) * 3300 // 4096

    def set_adc(self, raw: int) -> None:
        if not 0 <= raw <= 4095:
            raise ValueError(f"ADC reading must be 0..4095, got {raw}")
        self.adc = raw

    # -- output ----------------------------------------------------------------------------
    def echo_enabled(self) -> bool:
        return bool(self.echo)

    def write_out(self, data: bytes) -> None:
        """Raw output (echo, prompts, partial lines) into the TX ring."""
        self.uart.write(bytes(data))

    def emit(self, line: bytes | str) -> None:
        """One output line; CRLF is added."""
        if isinstance(line, str):
            line = line.encode("utf-8")
        self.uart.write(bytes(line) + CRLF)

    def tx_pending(self) -> int:
        """Bytes queued in the TX ring (R5+ report throttle, §6.2)."""
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
    def tick(self) -> None:
        """One millisecond: wire, LEDs, start-up or main loop (input, ports, controllers, faults)."""
        self.now += 1
        self.uart.tick()
        self._refresh_leds()
        if not self.startup.done:
            self.startup.tick()
            if self.startup.done:
                self._early_bytes = self.uart.rx_available()
            return
        self.poll()
        for port in self.ports:
            port.tick(self.now)
        for controller in self.controllers:
            controller.tick(self.now)
        self.faults.tick(self.now)

    def poll(self) -> None:
        """Process the received bytes now (the main loop runs far faster than 1 kHz)."""
        if not self.startup.done:
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
        finally:
            if pos < len(data):
                rx.extendleft(reversed(data[pos:]))

    def _refresh_leds(self) -> None:
        key = (self.ledmode, self.adc)
        if key == self._led_key:
            return          # H10: same inputs, same code (this ran every millisecond)
        self._led_key = key
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
            record.error, record.commands, record.unknown = run_line(self, line)
            if self.echo:
                self.write_out(b"P%d>" % self.port)
        for observer in list(self.line_observers):
            observer(record)
        return record

"""One HAT port: the device state machine of FIRMWARE-BEHAVIOUR.md#fb-port-reset, #fb-async,
#fb-device-messages and #fb-timing.

``Hat`` builds ``Port(hat, index)`` and calls ``tick(now)`` every millisecond once the start-up
is done. The port owns the wire to the plugged-in device model (``emulator/devices/``): bytes
the device sends arrive at its baud rate (the profile's ``device_setup`` baud during setup, then
the device's rate), and frames the HAT sends reach the device at once. Phases:

- ``scan``: each pass through *state 0* resets the port's controller (``port_initpwm``), prints
  ``P<p>: disconnected`` if something was connected (profile ``disconnected_line``) and starts an
  ID scan of ``passive_scan_ms``. An empty port repeats this every ``empty_port_reset_ms``. The scan
  samples the ID lines eight times; a device plugged in or out meanwhile gives a mixed signature
  (an active device counts only when it was there for the first sample).
- passive: a non-zero ID read on 6 scans in a row (back to back) prints
  ``P<p>: connected to passive ID <n>``; then the port is rescanned after a 100 ms pause (no
  pause for the button, ID 5). A scan that reads another ID or none goes back to state 0.
  ``passive_port_reset_each_scan`` (R1): every rescan passes state 0 (controller reset,
  connected flag cleared during the scan) and the connect line repeats after each scan.
  Button (ID 5, ``button_events``): ``P<p>: button pressed/released`` when the state changes.
- active: a scan that sees an active device waits 100 ms (RX held low), prints
  ``P<p>: connecting to active device``, turns the UART on at the set-up rate and hands over to a
  ``DeviceConversation`` (``emulator/ports/device_conversation.py``: setup, handshake, data phase,
  timeouts). When the conversation fails the port prints why and disconnects (R2+: ``disconnected``
  on the next pass).

Beside it: the port's UART (receive sync, LPF2 framing, the 4-slot message queue, debug-1
trace) is ``emulator/ports/device_uart.py``; the per-mode payload store ``emulator/ports/mode_store.py``.
Debug bit 4 (#fb-debug-signatures, the scan's signature line) is printed here.

Interfaces other modules use: ``connected``, ``mode_data(mode)``, ``describe()``, ``settled``,
``send_to_device(frame)``, ``send_select(mode)``, the world actions ``plug(spec)``, ``unplug()``,
``device_data(mode, payload)``, ``press_button(pressed)``, ``set_data_rate(ms)``,
``hold_shaft(held)``, ``set_shaft_position(deg)``; ``due`` and ``wake()`` (below).

Idle milliseconds: most milliseconds a port (and its device) does nothing, so after each tick
the port works out ``due``, the first millisecond at which its tick may do something (a timer,
a byte on the wire, a device step; see :meth:`Port._next_due`), and the Hat skips it until
then. Whatever changes the port's state from outside a tick (commands, world actions, the
motor driver's output) calls :meth:`Port.wake`, so skipping never changes what happens when.
"""
from __future__ import annotations

import math
import random
from collections import deque
from typing import Deque, Dict, List, Optional, Tuple

from ...protocol.profiles import passive_signature_ids
from ..commands.listing import active_dump, empty_line, passive_line
from ..devices import ActiveDevice, Device, PassiveDevice, make_device
from ..devices.active import setup_timing
from ..devices.info import DeviceInfo
from ..devices.passive import BUTTON_ID, BUTTON_RELEASED
from ..devices.port_actions import PortActions
from ..services import PortServices
from . import lpf2
from .data_reports import Reporter
from .device_conversation import RESTART, DeviceConversation, Failure
from .device_uart import PortUart
from .mode_store import ModeStore

__all__ = ["Port", "DETECT_MATCHES", "RESCAN_PAUSE_MS", "ACTIVE_DETECT_MS", "SIGNATURE_EMPTY",
           "SIGNATURE_ACTIVE"]

DETECT_MATCHES = 6          # scans in a row that must read the same passive ID
RESCAN_PAUSE_MS = 100       # pause between rescans of a connected passive device (not ID 5)
ACTIVE_DETECT_MS = 100      # RX held low this long -> "connecting to active device"
UART_BEFORE_LINE_MS = 2     # the receiver is on (the device sets up) this long before that line
# A scan reads the ID lines 8 times: the first sample SCAN_SETTLE_MS + 1 ms after the scan starts,
# then one every (scan - SCAN_SETTLE_MS) / 8 ms (docs/EMULATOR-MODELS.md "Device set-up timing").
SCAN_SETTLE_MS = 10
SCAN_SAMPLES = 8
# ID-pin signatures the scan reads (debug 4) when nothing, or an active device, is attached.
SIGNATURE_EMPTY = 0x0CC0
SIGNATURE_ACTIVE = 0x00CF
_WAITING = ("scan", "pause", "idle", "detect")   # phases that only wait for ``_next``


class Port(PortActions):
    """The HAT side of one device port (see the module docstring)."""

    def __init__(self, hat: PortServices, index: int):
        self.hat = hat          # the HAT as far as a port may use it
        self.index = index
        f = hat.profile.features
        self.scan_ms: int = f["passive_scan_ms"]
        self.empty_cycle_ms: int = f["empty_port_reset_ms"]
        self.print_disconnected = bool(f["disconnected_line"])
        self.reset_each_scan = bool(f["passive_port_reset_each_scan"])
        self.repeat_connect = bool(f["passive_connect_repeats"])
        self.button_events = bool(f["button_events"])
        self.matrix_autopower = bool(f["matrix_autopower"])
        # The release's signature -> ID table, and the "possibly active" rule (id 99): #fb-debug-signatures.
        (self._signature_ids, self._active_mask, self._active_value,
         self._active_id) = passive_signature_ids(f["passive_signature_table"])
        self.rng = random.Random((hat.seed or 0) * 7919 + index)
        self.device: Optional[Device] = None    # what is plugged in (the world)
        self.reporter = Reporter(self)
        self.info: Optional[DeviceInfo] = None  # the parsed setup of the active device
        self.combis: Dict[int, List[Tuple[int, int]]] = {}
        self.passive_id = 0                     # connected passive ID (0 = none)
        self.established = False
        self.button_pressed = False             # stored button state (kept over disconnects)
        self.modes = ModeStore()                # DATA payloads of the active device
        self.uart = PortUart(hat, index)
        self._phase = "state0"
        # ID-line changes during the scan running now: (ms of the change, signature before it)
        self._scan_changes: List[Tuple[int, int]] = []
        self._next = 0          # when a waiting phase (_WAITING) ends
        self._scan_start = 0
        self._cycle_start = 0
        self._matches = 0
        self._scan_id = 0
        self._pending_disconnect = False
        # The wire from the device: (arrival ms, byte), paced at the device's baud rate.
        self._wire: Deque[Tuple[float, int]] = deque()
        self._wire_free = 0.0
        self.link: Optional[DeviceConversation] = None   # the conversation with an active device
        self.due: float = 0     # the Hat ticks the port from this virtual ms on (0: at once)

    def wake(self) -> None:
        """Something outside the port's tick changed its state: tick it again from the next ms."""
        self.due = 0
        self.hat.wake()
        dev = self.device
        if isinstance(dev, ActiveDevice):
            dev.inputs_changed()

    # -- what other modules read ---------------------------------------------------------------
    @property
    def connected(self) -> bool:
        """The firmware's "device connected" flag: passive connected or active established."""
        return self.passive_id != 0 or self.established

    @property
    def settled(self) -> bool:
        """False while a plugged-in device is still being detected or set up."""
        dev = self.device
        if dev is None:
            return True
        if isinstance(dev, PassiveDevice):
            return self.passive_id != 0
        return self.established or dev.dead

    def mode_data(self, mode: int) -> Optional[bytes]:
        """The payload stored for ``mode`` (padded store) as the controllers' pass at the start of
        this millisecond sees it, None if none since connect."""
        return self.modes.at_tick_start(mode, self.hat.now)

    def stored(self, mode: int) -> Tuple[bytes, int]:
        """(payload store, received length) of ``mode``; zeros and 0 when nothing arrived."""
        return self.modes.stored(mode)

    def describe(self) -> List[str]:
        """The lines ``list`` prints for this port."""
        if self.established and self.info is not None:
            return active_dump(self.index, self.info)
        if self.passive_id:
            return [passive_line(self.index, self.passive_id)]
        return [empty_line(self.index)]

    # -- sending to the device -------------------------------------------------------------------
    def send_to_device(self, frame: bytes) -> None:
        """A framed message from the HAT; silently dropped while the port UART is off."""
        if not self.uart.on:
            return
        self.wake()
        self.hat.event("dev", port=self.index, hex=frame.hex(" ").upper())
        dev = self.device
        for msg in self.uart.transmit(frame):
            if isinstance(dev, ActiveDevice):
                dev.receive(msg, self.hat.now)

    def send_select(self, mode: int) -> None:
        for frame in lpf2.select_frames(mode):
            self.send_to_device(frame)

    # -- world actions ---------------------------------------------------------------------------
    def plug(self, spec) -> None:
        """Plug a device in (SPEC string or parsed tuple; None/"none" = unplug)."""
        device = make_device(spec, random.Random(self.rng.random()))
        self.unplug()
        if device is None:
            return
        if isinstance(device, ActiveDevice):
            device.port = self         # it reads the motor drive and notes through its port
        self._note_pin_change()
        self.device = device
        self.wake()

    def unplug(self) -> None:
        if isinstance(self.device, ActiveDevice):
            self.device.port = None
        if self.device is not None:
            self._note_pin_change()
        self.device = None
        self._wire.clear()
        self.wake()

    def _note_pin_change(self) -> None:
        """The ID lines are about to change: the scan running now read the old ones until now."""
        if self._phase == "scan":
            self._scan_changes.append((self.hat.now, self._signature()))

    # -- time ------------------------------------------------------------------------------------
    def tick(self, now: int) -> None:
        """One millisecond of the port; then ``due`` says when the next one can matter."""
        self._tick(now)
        self.due = self._next_due(now)

    def _next_due(self, now: int) -> float:
        """The first millisecond after ``now`` in which :meth:`_tick` may change anything, given
        the state now (a wake covers later changes). Conservative: when unsure, ``now + 1``."""
        dev = self.device
        if isinstance(dev, ActiveDevice):
            dev_due = dev.next_due(now)
            if dev_due <= now + 1:
                return now + 1             # e.g. a moving motor: no need to look further
        else:
            dev_due = math.inf
        if self._pending_disconnect or self.uart.queue:
            return now + 1
        phase = self._phase
        if phase in _WAITING:
            due = self._next
        elif phase == "active" and self.link is not None:
            due = self.link.next_due(now)
        elif phase == "gone":
            due = math.inf                 # only waits for the pending disconnect
        else:
            return now + 1                 # state 0: every millisecond
        if self._wire:
            due = min(due, math.ceil(self._wire[0][0]))   # the next byte's arrival
        return min(due, dev_due)

    def _tick(self, now: int) -> None:
        dev = self.device
        if isinstance(dev, ActiveDevice):
            frames = dev.tick(now)
            if frames:
                self._from_device(frames, now, dev.baud)
        if self._wire:
            self._receive(now)
        if self._pending_disconnect:
            self._pending_disconnect = False
            self._state0(now)
        phase = self._phase
        if phase in _WAITING:
            if now < self._next:
                return
            if phase == "scan":
                self._scan_done(now)
            elif phase == "pause":
                self._start_rescan(now)
            elif phase == "idle":
                self._state0(now)
            else:
                self._connecting(now)
        elif phase == "state0":
            self._state0(now)
        elif phase == "active" and self.link is not None:
            self._link_tick(self.link, now)

    # -- scanning ----------------------------------------------------------------------------------
    def _state0(self, now: int) -> None:
        """Pass through state 0: controller reset, disconnect report, start a scan."""
        self.hat.controllers[self.index].reset()      # port_initpwm (#fb-port-reset)
        if self.connected and self.print_disconnected:
            self._line("disconnected")
        if self.established:
            self.reporter.connection_changed()
        self.passive_id = 0
        self.established = False
        self._uart_off()
        self._cycle_start = now
        self._begin_scan(now)

    def _begin_scan(self, now: int) -> None:
        self._scan_changes = []
        self._scan_start = now
        self._phase = "scan"
        self._next = now + self.scan_ms

    def _start_rescan(self, now: int) -> None:
        if self.reset_each_scan:
            # R1: every scan of a passive port passes state 0 (connected flag cleared, reset).
            self.hat.controllers[self.index].reset()
            self.passive_id = 0
            self._cycle_start = now
        self._begin_scan(now)

    def _signature(self) -> int:
        """The signature the ID lines show now."""
        dev = self.device
        if isinstance(dev, PassiveDevice):
            return dev.signature_in(self._signature_ids)
        if isinstance(dev, ActiveDevice) and dev.talking:
            return SIGNATURE_ACTIVE
        return SIGNATURE_EMPTY

    def _scanned_signature(self) -> int:
        """The signature the scan read, sample by sample: sample k gives bit k (pin 5) and bit
        8+k (pin 6) of the lines as they were then, so a device plugged in or out during the
        scan gives a mix (an active device plugged in after the first sample is no ID 99)."""
        signature = self._signature()
        if not self._scan_changes:
            return signature
        pitch = (self.scan_ms - SCAN_SETTLE_MS) // SCAN_SAMPLES
        mixed = 0
        for k in range(SCAN_SAMPLES):
            at = self._scan_start + SCAN_SETTLE_MS + 1 + k * pitch
            # A change in ms t (between two ticks) is seen from the sample of tick t + 1 on.
            seen = next((before for t, before in self._scan_changes if t >= at), signature)
            mixed |= seen & ((1 << k) | (1 << (8 + k)))
        return mixed

    def _read_pins(self) -> Tuple[int, int]:
        """(signature, table ID) as the scan reads them: the ID from the release's table,
        ``_active_id`` (99) for a possible active device, 0 for unknown codes (#fb-debug-signatures)."""
        signature = self._scanned_signature()
        if signature & self._active_mask == self._active_value:
            return signature, self._active_id
        return signature, self._signature_ids.get(signature, 0)

    def _scan_done(self, now: int) -> None:
        signature, table_id = self._read_pins()
        if self._scan_changes and table_id not in (0, self._active_id):
            # A passive ID read by a scan during which a device came or went: the scan does not
            # count towards the six (**model**: a mix of two signatures may read as a third ID).
            signature, table_id = SIGNATURE_EMPTY, 0
        if self.hat.debug & 4:
            self._line(f"D5 signature={signature:04X} id={table_id}")
        active = table_id == self._active_id
        pid = 0 if active else table_id
        was = self.passive_id
        if active or pid == 0 or (was and pid != was):
            self._matches = self._scan_id = 0
            if was:
                self._state0(now)          # lost, or another device: state 0 reports it
            elif active:
                self._phase = "detect"     # RX held low: an active device wants to talk
                self._next = now + ACTIVE_DETECT_MS
            else:
                self._idle(now)
            return
        if pid != self._scan_id:
            self._scan_id, self._matches = pid, 0
        self._matches += 1
        if was:
            self._button(signature)
            self._pause(now, pid)
        elif self._matches >= DETECT_MATCHES:
            self.passive_id = pid
            self._line(f"connected to passive ID {pid}")
            self._button(signature)
            self._pause(now, pid)
        else:
            self._begin_scan(now)          # detection scans run back to back

    def _idle(self, now: int) -> None:
        """Nothing found: back to state 0 once the empty-port cycle is over."""
        due = self._cycle_start + self.empty_cycle_ms
        if due <= now:
            self._state0(now)
        else:
            self._phase = "idle"
            self._next = due

    def _pause(self, now: int, pid: int) -> None:
        self._phase = "pause"
        self._next = now + (0 if pid == BUTTON_ID else RESCAN_PAUSE_MS)
        if self.reset_each_scan and self.repeat_connect:
            # R1: the next rescan passes state 0 and reconnects after one scan; keep the count.
            self._matches = DETECT_MATCHES - 1

    def _button(self, signature: int) -> None:
        if self.passive_id != BUTTON_ID or not self.button_events:
            return
        pressed = signature != BUTTON_RELEASED
        if pressed != self.button_pressed:
            self.button_pressed = pressed
            self._line("button pressed" if pressed else "button released")

    # -- active device -----------------------------------------------------------------------------
    def _connecting(self, now: int) -> None:
        dev = self.device
        if not (isinstance(dev, ActiveDevice) and dev.talking):
            self._state0(now)
            return
        self._line("connecting to active device")
        # The port's receiver went on, and the device began its set-up, 2 ms before the line
        # (the firmware in the loop: docs/EMULATOR-MODELS.md "Start-up timeline").
        now -= UART_BEFORE_LINE_MS
        self.link = DeviceConversation(self.hat, self.index, self.uart, self.modes, self.reporter,
                               self.send_to_device, now)
        self.info = self.link.info
        self.combis = {}
        self.modes.clear()
        self.reporter.connection_changed()
        self.uart.start(now, setup_timing(self.hat.profile.features,
                                          bool(getattr(self.hat, "fast_setup", False)))[1])
        self._phase = "active"
        dev.begin_setup(now)

    def _link_tick(self, link: DeviceConversation, now: int) -> None:
        outcome = link.tick(now)
        if outcome is None:
            return
        if isinstance(outcome, Failure):
            self._fail(now, outcome.text)
        elif outcome == RESTART:
            self._state0(now)          # no TYPE seen: restart silently
        else:                          # ESTABLISHED
            self.established = True
            dev = self.device
            if self.matrix_autopower and dev is not None and dev.entry.get("category") == "light":
                self.hat.controllers[self.index].autopower()   # constant 1.0, coast cleared (#fb-led-matrix)

    def _fail(self, now: int, text: str) -> None:
        """A setup or data-phase failure: print, reset the select state, rescan."""
        self._line(text)
        if self.established:
            self.reporter.connection_changed()
        dev = self.device
        if isinstance(dev, ActiveDevice):
            dev.reset_link()
            self._wire.clear()             # the device restarts: what it was sending stops
        self._uart_off()
        if self.established:
            # R2+: "disconnected" follows on the next loop pass (printed by state 0).
            self._phase = "gone"
            self._pending_disconnect = True
        else:
            self._state0(now)

    # -- the wire from the device ------------------------------------------------------------------
    def _from_device(self, frames: List[bytes], now: int, baud: int) -> None:
        """The device's frames as bytes on the wire, each arriving 10 bit times after the last."""
        byte_ms = 10000.0 / baud
        t = max(float(now), self._wire_free)
        for frame in frames:
            for b in frame:
                t += byte_ms
                self._wire.append((t, b))
        self._wire_free = t

    def _receive(self, now: int) -> None:
        """Bytes that arrived by ``now`` go to the port UART (which may queue messages)."""
        wire, uart = self._wire, self.uart
        while wire and wire[0][0] <= now:
            t, b = wire.popleft()
            uart.receive(t, b)

    def _uart_off(self) -> None:
        self.uart.stop()
        self.link = None

    def _line(self, text: str) -> None:
        self.hat.emit(f"P{self.index:X}: {text}")


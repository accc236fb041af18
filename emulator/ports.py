"""One HAT port: the device state machine of FIRMWARE-FACTS §4.2, §5, §8 and §10.

``Hat`` builds ``Port(hat, index)`` and calls ``tick(now)`` every millisecond once the start-up
is done. The port owns the wire to the plugged-in device model (``emulator/devices/``): bytes
the device sends arrive at its baud rate (the profile's ``device_setup`` baud during setup,
then the device's rate), and
frames the HAT sends reach the device at once. Phases:

- ``scan``: each pass through *state 0* resets the port's controller (``port_initpwm``), prints
  ``P<p>: disconnected`` if something was connected (profile ``disconnected_line``) and starts an
  ID scan of ``passive_scan_ms``. An empty port repeats this every ``empty_port_reset_ms``.
- passive: a non-zero ID read on 6 scans in a row (back to back) prints
  ``P<p>: connected to passive ID <n>``; then the port is rescanned after a 100 ms pause (no
  pause for the button, ID 5). A scan that reads another ID or none goes back to state 0.
  ``passive_port_reset_each_scan`` (R1): every rescan passes state 0 (controller reset,
  connected flag cleared during the scan) and the connect line repeats after each scan.
  Button (ID 5, ``button_events``): ``P<p>: button pressed/released`` when the state changes.
- active: a scan that sees an active device waits 100 ms (RX held low), prints
  ``P<p>: connecting to active device`` and turns the UART on at the set-up rate. Bytes count only after
  100 ms of silence. Setup messages fill a :class:`DeviceInfo`; the device's ACK starts the
  handshake: +10 ms SPEED, +100 ms ACK, +10 ms baud switch (``set baud rate to <baud>``, no
  prefix), +1 ms the ``list`` dump and ``P<p>: established serial communication with active ID
  xx``. In the data phase the HAT sends NACK every 100 ms, handles one queued message per pass,
  and disconnects after more than 500 ms without a message (setup: 2000 ms).

The active device's messages queue in a 4-slot queue (``MQ overrun!`` when more than 4 complete
within one millisecond: the emulated main loop drains the queue once per millisecond).
Debug bits (§7.4): 1 serial trace, 4 signatures, 8 DATA payloads, 32 unknown messages.

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

from ..protocol.profiles import passive_signature_ids
from . import lpf2
from .devices import ActiveDevice, MotorDevice, PassiveDevice, make_device
from .devices.info import DeviceInfo
from .devices.passive import BUTTON_ID, BUTTON_RELEASED
from .listing import active_dump, empty_line, passive_line
from .reporting import Reporter
from .services import PortServices

__all__ = ["Port", "DETECT_MATCHES", "RESCAN_PAUSE_MS", "ACTIVE_DETECT_MS", "SYNC_GAP_MS",
           "SETUP_TIMEOUT_MS", "DATA_TIMEOUT_MS", "NACK_PERIOD_MS", "QUEUE_SLOTS",
           "MAX_ERRORS", "HANDSHAKE_SPEED_MS", "HANDSHAKE_ACK_MS", "HANDSHAKE_SWITCH_MS",
           "HANDSHAKE_DUMP_MS", "SIGNATURE_EMPTY", "SIGNATURE_ACTIVE"]

DETECT_MATCHES = 6          # scans in a row that must read the same passive ID
RESCAN_PAUSE_MS = 100       # pause between rescans of a connected passive device (not ID 5)
ACTIVE_DETECT_MS = 100      # RX held low this long -> "connecting to active device"
SYNC_GAP_MS = 100           # receive sync: bytes are ignored until a gap this long
SETUP_TIMEOUT_MS = 2000
DATA_TIMEOUT_MS = 500
NACK_PERIOD_MS = 100
QUEUE_SLOTS = 4
MAX_ERRORS = 5              # checksum + framing errors above this disconnect
HANDSHAKE_SPEED_MS = 10     # after the device's ACK
HANDSHAKE_ACK_MS = 110
HANDSHAKE_SWITCH_MS = 120
HANDSHAKE_DUMP_MS = 121
MIN_BAUD, MAX_BAUD = 2400, 115200
SETUP_BAUD = 2400
# ID-pin signatures the scan reads (debug 4) when nothing, or an active device, is attached.
SIGNATURE_EMPTY = 0x0CC0
SIGNATURE_ACTIVE = 0x00CF
_WAITING = ("scan", "pause", "idle", "detect")   # phases that only wait for ``_next``
_MODE_BUFFER = 132          # per-mode payload store: offsets up to 127 plus a 4-byte value


class Port:
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
        # §7.4: the release's signature -> ID table, and the "possibly active" rule (id 99).
        (self._signature_ids, self._active_mask, self._active_value,
         self._active_id) = passive_signature_ids(f["passive_signature_table"])
        self.rng = random.Random((hat.seed or 0) * 7919 + index)
        self.device = None                      # what is plugged in (the world)
        self.reporter = Reporter(self)
        self.info: Optional[DeviceInfo] = None  # the parsed setup of the active device
        self.combis: Dict[int, List[Tuple[int, int]]] = {}
        self.passive_id = 0                     # connected passive ID (0 = none)
        self.established = False
        self.button_pressed = False             # stored button state (kept over disconnects)
        self._modedata: Dict[int, bytearray] = {}
        self._modelen: Dict[int, int] = {}
        self._phase = "state0"
        self._next: Optional[int] = None
        self._cycle_start = 0
        self._matches = 0
        self._scan_id = 0
        self._pending_disconnect = False
        self._uart_on = False
        self._baud = SETUP_BAUD
        self._wire: Deque[Tuple[float, int]] = deque()
        self._wire_free = 0.0
        self._rx = lpf2.Assembler()
        self._rx_synced = False
        self._rx_last = 0.0
        self._queue: Deque[lpf2.Message] = deque()
        self._last_msg = 0
        self._errors = 0
        self._handshake_at: Optional[int] = None    # when the next handshake step is due
        self._handshake_step = 0
        self._next_nack: Optional[int] = None
        self._dev_rx = lpf2.Assembler(keep_system=True)
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
        """The latest payload stored for ``mode`` (padded store), None if none since connect."""
        buf = self._modedata.get(mode)
        return None if buf is None else bytes(buf)

    def stored(self, mode: int) -> Tuple[bytes, int]:
        """(payload store, received length) of ``mode``; zeros and 0 when nothing arrived."""
        buf = self._modedata.get(mode)
        if buf is None:
            return bytes(_MODE_BUFFER), 0
        return bytes(buf), self._modelen.get(mode, 0)

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
        if not self._uart_on:
            return
        self.wake()
        self.hat.event("dev", port=self.index, hex=frame.hex(" ").upper())
        dev = self.device
        self._dev_rx.reset()
        for b in frame:
            msg = self._dev_rx.feed(b)
            if msg is not None and isinstance(dev, ActiveDevice):
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
        device.port = self
        self.device = device
        self.wake()

    def unplug(self) -> None:
        if self.device is not None:
            self.device.port = None
        self.device = None
        self._wire.clear()
        self.wake()

    def _active(self, what: str) -> ActiveDevice:
        dev = self.device
        if not isinstance(dev, ActiveDevice):
            raise ValueError(f"{what}: no active device on port {self.index}")
        return dev

    def device_data(self, mode: int, payload) -> None:
        """``@data P M HH..`` (payload bytes or a list of ints) / ``@data P M auto`` (None)."""
        data = None if payload is None else bytes(payload)
        self._active("@data").world_data(int(mode), data)
        self.wake()

    def set_data_rate(self, ms: int) -> None:
        self._active("@rate").set_rate(int(ms))
        self.wake()

    def press_button(self, pressed: bool) -> None:
        dev = self.device
        if not isinstance(dev, PassiveDevice):
            raise ValueError(f"@button: no passive device on port {self.index}")
        dev.press(pressed)
        self.wake()

    def _motor(self, what: str) -> MotorDevice:
        dev = self.device
        if not isinstance(dev, MotorDevice):
            raise ValueError(f"{what}: no motor on port {self.index}")
        return dev

    def hold_shaft(self, held: bool) -> None:
        self._motor("@hold").hold(held)
        self.wake()

    def set_shaft_position(self, deg: float) -> None:
        self._motor("@pos").set_position(deg)
        self.wake()

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
        if self._pending_disconnect or self._queue:
            return now + 1
        phase = self._phase
        if phase in _WAITING:
            due = self._next
        elif phase == "data":
            due = min(self.reporter.next_due(now), self._next_nack,
                      self._last_msg + DATA_TIMEOUT_MS + 1)
        elif phase == "gone":
            due = math.inf                 # only waits for the pending disconnect
        else:
            return now + 1                 # state 0, setup and handshake: every millisecond
        if self._wire:
            due = min(due, math.ceil(self._wire[0][0]))   # the next byte's arrival
        return min(due, dev_due)

    def _tick(self, now: int) -> None:
        dev = self.device
        if isinstance(dev, ActiveDevice):
            frames = dev.tick(now)
            if frames:
                self._from_device(frames, now)
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
        elif phase in ("setup", "handshake"):
            self._setup_tick(now)
        elif phase == "data":
            self._data_tick(now)

    # -- scanning ----------------------------------------------------------------------------------
    def _state0(self, now: int) -> None:
        """Pass through state 0: controller reset, disconnect report, start a scan."""
        self.hat.controllers[self.index].reset()      # port_initpwm (§4.2)
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
        self._phase = "scan"
        self._next = now + self.scan_ms

    def _start_rescan(self, now: int) -> None:
        if self.reset_each_scan:
            # R1: every scan of a passive port passes state 0 (connected flag cleared, reset).
            self.hat.controllers[self.index].reset()
            self.passive_id = 0
            self._cycle_start = now
        self._begin_scan(now)

    def _read_pins(self) -> Tuple[int, int]:
        """(signature, table ID) as the scan reads them: the ID from the release's table,
        ``_active_id`` (99) for a possible active device, 0 for unknown codes (§7.4)."""
        dev = self.device
        if isinstance(dev, PassiveDevice):
            signature = dev.signature_in(self._signature_ids)
        elif isinstance(dev, ActiveDevice) and dev.talking:
            signature = SIGNATURE_ACTIVE
        else:
            signature = SIGNATURE_EMPTY
        if signature & self._active_mask == self._active_value:
            return signature, self._active_id
        return signature, self._signature_ids.get(signature, 0)

    def _scan_done(self, now: int) -> None:
        signature, table_id = self._read_pins()
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

    # -- active setup ------------------------------------------------------------------------------
    def _connecting(self, now: int) -> None:
        dev = self.device
        if not (isinstance(dev, ActiveDevice) and dev.talking):
            self._state0(now)
            return
        self._line("connecting to active device")
        self.info = DeviceInfo()
        self.combis = {}
        self._modedata.clear()
        self._modelen.clear()
        self.reporter.connection_changed()
        self._uart_on = True
        self._baud = SETUP_BAUD
        self._rx.reset()
        self._rx_synced = False
        self._rx_last = float(now)
        self._queue.clear()
        self._last_msg = now
        self._errors = 0
        self._handshake_at = None
        self._phase = "setup"
        dev.begin_setup(now)

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

    def _setup_tick(self, now: int) -> None:
        if self._phase == "setup":
            while self._queue:
                msg = self._queue.popleft()
                self._last_msg = now
                if not msg.ok:
                    self._fail(now, "checksum error: disconnecting")
                    return
                if msg.header == lpf2.ACK:
                    if self.info is None or self.info.type_id is None:
                        self._state0(now)          # no TYPE seen: restart silently
                        return
                    self._phase = "handshake"
                    self._handshake_at = now + HANDSHAKE_SPEED_MS
                    self._handshake_step = 0
                    break
                self._setup_message(msg)
            if self._phase == "setup":
                if now - self._last_msg > SETUP_TIMEOUT_MS:
                    self._fail(now, "timeout during setup phase: disconnecting")
                return
        # Each step waits its delay from the step before (the firmware's per-port `delay`: a
        # step that ran late, e.g. after a main-loop stall, shifts the ones after it).
        if self._handshake_at is None or now < self._handshake_at:
            return
        info = self.info
        step = self._handshake_step
        self._handshake_step += 1
        if step == 0:
            self.send_to_device(lpf2.speed_frame(info.baud))
            self._handshake_at = now + HANDSHAKE_ACK_MS - HANDSHAKE_SPEED_MS
        elif step == 1:
            self.send_to_device(bytes([lpf2.ACK]))
            self._handshake_at = now + HANDSHAKE_SWITCH_MS - HANDSHAKE_ACK_MS
        elif step == 2:
            self._baud = max(MIN_BAUD, min(MAX_BAUD, info.baud))
            self.hat.emit(f"set baud rate to {info.baud}")
            self._handshake_at = now + HANDSHAKE_DUMP_MS - HANDSHAKE_SWITCH_MS
        else:
            self._establish(now)

    def _setup_message(self, msg: lpf2.Message) -> None:
        if self.info.apply(msg) or not self.hat.debug & 32:
            return
        if msg.msg_class == lpf2.INFO:
            self._line(f"type=80 cmd={msg.cmd:02X}  payload={_payload_hex(msg.payload)}")
        else:
            self.hat.emit(f"P{self.index:X} message type={msg.header:02X}")

    def _establish(self, now: int) -> None:
        for line in active_dump(self.index, self.info):
            self.hat.emit(line)
        type_id = self.info.type_id
        self._line(f"established serial communication with active ID {type_id:02X}")
        self.established = True
        self._phase = "data"
        self._last_msg = now
        self._next_nack = now + NACK_PERIOD_MS
        dev = self.device
        if self.matrix_autopower and dev is not None and dev.entry.get("category") == "light":
            self.hat.controllers[self.index].autopower()   # constant 1.0, coast cleared (§7.1)

    # -- data phase --------------------------------------------------------------------------------
    def _data_tick(self, now: int) -> None:
        # The main loop makes many passes per millisecond; each pass handles one queued
        # message and then runs the report engine (so rate 0 reports once per message).
        if not self._queue:
            self.reporter.tick(now)
        while self._queue:
            self._data_message(self._queue.popleft(), now)
            if self._phase != "data":
                return
            self.reporter.tick(now)
        if now >= self._next_nack:
            self._next_nack += NACK_PERIOD_MS
            self.send_to_device(bytes([lpf2.NACK]))
        if now - self._last_msg > DATA_TIMEOUT_MS:
            self._fail(now, "timeout during data phase: disconnecting")

    def _data_message(self, msg: lpf2.Message, now: int) -> None:
        self._last_msg = now
        if not msg.ok:
            self._errors += 1
            if self._errors > MAX_ERRORS:
                self._fail(now, f"too many errors (0+{self._errors}): disconnecting")
            return
        if msg.msg_class == lpf2.DATA:
            mode = msg.code
            buf = self._modedata.setdefault(mode, bytearray(_MODE_BUFFER))
            buf[:len(msg.payload)] = msg.payload
            self._modelen[mode] = len(msg.payload)
            if self.hat.debug & 8:
                self._line(f"DATA mode={mode:X} payload={_payload_hex(msg.payload)}")
            self.reporter.on_data(mode)
        elif self.hat.debug & 32:
            self._line(f"data-phase message type {msg.header:02X} payload={_payload_hex(msg.payload)}")

    # -- the wire from the device ------------------------------------------------------------------
    def _from_device(self, frames: List[bytes], now: int) -> None:
        if not frames:
            return
        dev = self.device
        byte_ms = 10000.0 / (dev.baud if dev is not None else SETUP_BAUD)
        t = max(float(now), self._wire_free)
        for frame in frames:
            for b in frame:
                t += byte_ms
                self._wire.append((t, b))
        self._wire_free = t

    def _receive(self, now: int) -> None:
        """The port UART interrupt: bytes that arrived by ``now`` become queued messages."""
        while self._wire and self._wire[0][0] <= now:
            t, b = self._wire.popleft()
            if not self._uart_on:
                continue
            if not self._rx_synced:
                gap = t - self._rx_last
                self._rx_last = t
                if gap < SYNC_GAP_MS:
                    self._trace(b, "n")
                    continue
                self._rx_synced = True
            self._rx_last = t
            state = self._rx.state
            msg = self._rx.feed(b)
            self._trace(b, "ACK" if msg is not None and msg.header == lpf2.ACK else state)
            if msg is None:
                continue
            self.hat.event("devrx", port=self.index, hex=msg.hex())
            if len(self._queue) >= QUEUE_SLOTS:
                self.hat.emit("MQ overrun!")
                continue
            self._queue.append(msg)

    def _trace(self, b: int, state: str) -> None:
        if self.hat.debug & 1:
            self.hat.write_out(f"{b:02X}{state}".encode("ascii"))

    def _uart_off(self) -> None:
        self._uart_on = False
        self._queue.clear()
        self._next_nack = None

    def _line(self, text: str) -> None:
        self.hat.emit(f"P{self.index:X}: {text}")


def _payload_hex(payload: bytes) -> str:
    return " ".join(f"{b:02x}" for b in payload)

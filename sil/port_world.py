"""The world around a firmware in the loop: the emulator's device models on the four ports,
the motor drivers' fault latches, the fault pins and the input voltage.

The device models are the emulator's own (``emulator/devices/``); here they are wired to the
firmware's port UARTs, ID lines and motor drivers instead of to the emulator's HAT model:

- bytes the firmware sends on a port (``p`` frames) are framed into LPF2 messages and handed to
  the device; what the device sends goes back as ``P`` frames at the device's baud rate;
- the firmware switching a port's receiver on (``u``) is the moment a device starts its set-up;
- the driver's output (``d``) is what the device's motor or light sees;
- plugging, pressing a button or a device going quiet changes the ID lines (``I``).

One model difference from the emulator: a device sends its set-up stream at 2400 baud, the
rate the firmware's port receiver listens at until the handshake (the emulator's HAT model
takes the profile's faster ``device_setup`` baud). World actions arrive through
``emulator.world.perform_line`` exactly as for the emulator.
"""
from __future__ import annotations

import math
import random
import struct
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Union

from ..emulator.api import DEFAULT_ADC
from ..emulator.devices import ActiveDevice, MotorDevice, PassiveDevice, make_device
from ..emulator.devices.port_actions import PortActions
from ..emulator.ports import lpf2
from ..emulator.ports.port import SIGNATURE_ACTIVE, SIGNATURE_EMPTY
from ..emulator.power_faults import FaultCauses
from .frames import NS_PER_MS, Frame, FrameType, encode

__all__ = ["SilWorld", "SilPort", "SETUP_BAUD", "SHAFT_MODES", "shows_shaft"]

SETUP_BAUD = 2400            # LPF2 devices start talking at 2400 baud
Duty = Union[int, str]
# The motor modes whose values come from the shaft (emulator/devices/motor.py, model_values); the
# others show zeros or what the HAT wrote. tests/sil/test_port_world.py holds the two together.
SHAFT_MODES = frozenset({"SPEED", "POS", "APOS", "CALIB"})


def shows_shaft(dev: MotorDevice) -> bool:
    """The selected mode, or a mode of its combi, reads the shaft."""
    combi = dev.combis.get(dev.mode)
    modes = [m for m, _dataset in combi] if combi else [dev.mode]
    return any(dev.modes.get(m, {}).get("name") in SHAFT_MODES for m in modes)


class _Profile:
    """What the device models read from their port's ``hat.profile``: the device-side timing."""

    def __init__(self, features: Mapping[str, Any]):
        self.features = dict(features)


class _DriveView:
    """``hat.controllers[p]`` as a device model sees it: the motor terminals of port p."""

    def __init__(self, world: SilWorld, index: int):
        self._world, self._index = world, index

    def motor_output(self) -> Duty:
        if self._world.faults.latched[self._index] is not None:
            return "coast"
        return self._world.ports[self._index].duty


class SilPort(PortActions):
    """One port: its device model, the wire from the firmware, the drive on its terminals."""

    def __init__(self, world: SilWorld, index: int):
        self.world, self.index = world, index
        self.device: Optional[Union[ActiveDevice, PassiveDevice]] = None
        self.duty: Duty = 0
        self.listening = False
        self.due: float = math.inf
        self._from_hat = lpf2.Assembler(keep_system=True)
        self._last_byte_ns = -(10 ** 18)
        self._id_sent: Optional[tuple] = None
        self.rng = random.Random(world.seed * 31 + index)

    @property
    def hat(self) -> SilWorld:           # the DevicePort face the device models use
        return self.world

    def wake(self) -> None:
        self.due = min(self.due, self.world.now_ms + 1)

    # -- ID lines --------------------------------------------------------------------------
    def id_lines(self) -> tuple:
        dev = self.device
        if isinstance(dev, PassiveDevice):
            return dev.signature, 1
        if isinstance(dev, ActiveDevice):
            return SIGNATURE_ACTIVE, 0 if dev.talking else 1
        return SIGNATURE_EMPTY, 1

    def sync_id(self) -> None:
        lines = self.id_lines()
        if lines != self._id_sent:
            self._id_sent = lines
            self.world.send(encode(FrameType.ID_LINES, 0, struct.pack("<HB", *lines), port=self.index))

    # -- world actions (emulator/world_actions.py names) -------------------------------------------
    def plug(self, spec) -> None:
        device = make_device(spec, random.Random(self.rng.random()))
        self.unplug()
        if device is None:
            return
        if isinstance(device, ActiveDevice):
            device.port = self           # type: ignore[assignment]  # a DevicePort in all but name
            if self.listening:
                device.begin_setup(self.world.now_ms)
        self.device = device
        self.sync_id()
        self.world.sync_drive_stops()
        self.wake()

    def cut(self) -> None:
        """The device stops what it was sending (unplugged, or starting its link over)."""
        now_ns = self.world.now_ms * NS_PER_MS - self.world.base_ns
        self.world.send(encode(FrameType.PORT_CUT, now_ns, port=self.index))

    def unplug(self) -> None:
        if isinstance(self.device, ActiveDevice):
            self.device.port = None
            self.cut()
        self.device = None
        self.sync_id()
        self.world.sync_drive_stops()

    def button_changed(self) -> None:
        self.sync_id()

    # -- the firmware's side of the wire ------------------------------------------------------
    def from_firmware(self, frame: Frame) -> None:
        now = frame.t // NS_PER_MS
        kind = frame.kind
        dev = self.device
        if kind == FrameType.TO_PORT:
            # A device's receiver starts over after a pause in the bytes, as the emulator's does
            # at each frame the HAT sends (emulator/ports/device_uart.py): a frame whose header promises
            # more bytes than came does not swallow the next one.
            baud = struct.unpack("<I", frame.payload[:4])[0] or 115200
            if frame.t - self._last_byte_ns > 2 * 10 * 1_000_000_000 // baud:
                self._from_hat.reset()
            self._last_byte_ns = frame.t
            msg = self._from_hat.feed(frame.payload[4])
            if msg is None:
                return
            self.world.event("dev", now, port=self.index, hex=msg.raw.hex(" ").upper())
            if isinstance(dev, ActiveDevice):
                dev.receive(msg, now)
                dev.inputs_changed()
                self.wake()
        elif kind == FrameType.RECEIVER:
            self.listening = bool(frame.payload[0])
            self._from_hat.reset()
            if isinstance(dev, ActiveDevice):
                self.world.now_ms = max(self.world.now_ms, now)
                self.cut()
                if self.listening:
                    dev.begin_setup(now)
                else:
                    dev.reset_link()
                self.wake()
        elif kind == FrameType.DRIVE:
            duty, driven = struct.unpack("<hB", frame.payload[:3])
            value: Duty = int(duty) if driven else "coast"
            if value != self.duty:
                if isinstance(dev, MotorDevice):
                    dev.step(now)          # the shaft moves under the old drive up to this instant
                self.duty = value
                self.world.event("pwm", now, port=self.index, value=value)
                if isinstance(dev, ActiveDevice):
                    dev.inputs_changed()
                self.wake()

    # -- the device's side -------------------------------------------------------------------
    def tick(self, now: int) -> None:
        dev = self.device
        if not isinstance(dev, ActiveDevice):
            self.due = math.inf
            return
        frames = dev.tick(now)
        if frames:
            data = b"".join(frames)
            for frame in frames:
                self.world.event("devrx", now, port=self.index, hex=frame.hex(" ").upper())
            for i in range(0, len(data), 4096):
                chunk = struct.pack("<I", dev.baud) + data[i:i + 4096]
                start = now * NS_PER_MS - self.world.base_ns
                self.world.send(encode(FrameType.PORT_BYTES, start, chunk, port=self.index))
        self.sync_id()                   # a device that stopped talking lets the line go
        self.due = dev.next_due(now)
        if isinstance(dev, MotorDevice) and self.due <= now + 1:
            # A moving shaft wants every millisecond, but only a sample can send: its physics
            # catches up in one step then (the drive cannot change unseen: every change of it
            # stops the firmware and steps the motor first, above; so do world actions and a
            # cleared fault latch, SilWorld.catch_up).
            self.due = dev.next_send(now)
            if (self.due > now + 1 and dev.state == "data" and dev.rate_ms <= 0
                    and not shows_shaft(dev)):
                # Nor can a sample find a new payload while what it shows does not come from the
                # shaft: the motor is ticked again when something reaches it (a message, a drive,
                # a world action), each of which wakes the port. (Half the firmware's stops for
                # the world in a fuzzing campaign were such samples.)
                self.due = math.inf


class _FaultLatches(FaultCauses):
    """The motor drivers' fault latches and the two fault pins (``@motorfault``, ``@portfault``):
    the world actions are the emulator's (emulator/power_faults.py); a change goes to the firmware's pins."""

    def __init__(self, world: SilWorld):
        super().__init__()
        self.world = world

    def _sync(self) -> None:
        motor_ok = all(f is None for f in self.latched)
        pins = bytes([0 if self.port_fault_low else 1, 1 if motor_ok else 0])
        self.world.send(encode(FrameType.FAULT_PINS, 0, pins))
        for p in range(4):
            flags = self.latched[p] or (0, 0, 0)
            self.world.send(encode(FrameType.FAULT_REGS, 0, bytes(int(f) & 0xFF for f in flags), port=p))
            self.world.ports[p].wake()

    def _fault_changed(self, ports: Sequence[int]) -> None:
        self._start_pulse(self.world.exact_ms)
        self._sync()

    def tick(self, now: float) -> None:
        """A port-fault pulse whose time is up lets the pin go high (``@portfault 1 MS``)."""
        if self._pulse_over(now):
            self._sync()

    def cleared(self, port: int, now: int) -> None:
        """The firmware cleared port's latch: it latches again at once if the cause remains."""
        if self.latched[port] is not None and not self.cause[port]:
            self.world.catch_up(now)         # the shaft moved without power up to now
            self.latched[port] = None
            self._sync()


class SilWorld:
    """Devices, faults and Vin around the firmware, in virtual milliseconds."""

    def __init__(self, layout: Mapping[int, Any], seed: int = 0,
                 features: Optional[Mapping[str, Any]] = None,
                 event: Optional[Callable[..., None]] = None):
        self.seed = seed
        given = dict(features or {})
        setup = dict(given.get("device_setup") or {})
        setup["baud"] = SETUP_BAUD
        given["device_setup"] = setup
        self.profile = _Profile(given)
        self.now_ms = 0
        self.exact_ms = 0.0            # now_ms with its fraction: a port-fault pulse starts and ends mid-ms
        self.base_ns = 0               # virtual time at the firmware's power-on (frames count from it)
        self._outbox: List[bytes] = []
        self._drive_stops = 0xFF           # the stand-in's default: every port's drive stops it
        self._event = event
        self.ports = [SilPort(self, i) for i in range(4)]
        self.controllers = [_DriveView(self, i) for i in range(4)]
        self.faults = _FaultLatches(self)
        for port in self.ports:
            port.sync_id()
        for index, spec in sorted(layout.items()):
            if spec is not None:
                self.ports[int(index)].plug(spec)
        self.sync_drive_stops()
        self.send(encode(FrameType.ADC, 0, struct.pack("<H", DEFAULT_ADC)))

    # -- what the device models and the world actions call ------------------------------------
    def send(self, frame: bytes) -> None:
        self._outbox.append(frame)

    def take_outbox(self) -> List[bytes]:
        out, self._outbox = self._outbox, []
        return out

    def note(self, text: str) -> None:
        self.event("note", self.now_ms, text=text)

    def event(self, kind: str, t: int, **fields: Any) -> None:
        if self._event is not None:
            self._event(kind, t, fields)

    def sync_drive_stops(self) -> None:
        """Tell the firmware which ports' drive changes must stop it: those with an active
        device (a motor's shaft, the light matrix's power). A passive device or an empty port
        does nothing with its drive, so its changes (a ramp's, every millisecond) travel with
        their times to the next stop instead of one round trip each."""
        mask = sum(1 << p.index for p in getattr(self, "ports", ()) if isinstance(p.device, ActiveDevice))
        if mask != self._drive_stops:
            self._drive_stops = mask
            self.send(encode(FrameType.DRIVE_STOPS, 0, bytes([mask])))

    def set_adc(self, raw: int) -> None:
        if not 0 <= int(raw) <= 4095:
            raise ValueError(f"ADC reading must be 0..4095, got {raw}")
        self.send(encode(FrameType.ADC, 0, struct.pack("<H", int(raw))))

    # -- time ------------------------------------------------------------------------------
    def from_firmware(self, frame: Frame) -> None:
        if frame.kind in (FrameType.TO_PORT, FrameType.RECEIVER, FrameType.DRIVE) and frame.port < 4:
            self.ports[frame.port].from_firmware(frame)
        elif frame.kind == FrameType.FAULTS_CLEARED and frame.port < 4:
            self.faults.cleared(frame.port, frame.t // NS_PER_MS)
        elif frame.kind == FrameType.LEDS:
            self.event("led", frame.t // NS_PER_MS, value=frame.payload[0])
        elif frame.kind == FrameType.BYTE_LOST and frame.payload:
            # A real HAT loses such a byte without a word; here it is said, so that a set-up the
            # firmware took only in part is explained (sil/README.md).
            self.event("note", frame.t // NS_PER_MS,
                       text=f"port {frame.port}: the PIO RX FIFO was full, a byte from the device "
                            f"was lost (0x{frame.payload[0]:02X})")

    def catch_up(self, now: int) -> None:
        """Step every motor's shaft to ``now`` under the drive it has had (before anything changes
        what its physics sees: a world action, a fault latch)."""
        for port in self.ports:
            if isinstance(port.device, MotorDevice):
                port.device.step(now)

    def next_due(self) -> float:
        """The first virtual ms at which a device has something to do (inf: none)."""
        pulse_end = self.faults.port_fault_until
        return min(min(port.due for port in self.ports), math.inf if pulse_end is None else pulse_end)

    def tick_due(self, now: int, exact_ms: Optional[float] = None) -> None:
        self.now_ms = now
        self.exact_ms = float(now) if exact_ms is None else exact_ms
        self.faults.tick(self.exact_ms)
        for port in self.ports:
            if port.due <= now:
                port.tick(now)

    def restart_grace(self, now: int) -> None:
        for port in self.ports:
            restart = getattr(port.device, "restart_grace", None)
            if restart is not None:
                restart(now)

    def layout(self) -> Dict[int, Any]:
        return {p.index: p.device for p in self.ports}

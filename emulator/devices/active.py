"""An active LPF2 device on its side of the port wire (setup handshake, modes, data messages).

The device model is built from its devices.json entry; subclasses (motor, sensors, matrix)
only say what values each mode holds. Behaviour modelled here (protocol/devices.json's ``_meta``
``data_output``):

- Handshake: when the HAT starts listening (``begin_setup``), the device waits ``start_ms``
  (so the HAT sees the 100 ms quiet gap it needs before it parses), then sends its setup stream
  at the set-up ``baud`` and waits. After the HAT's SPEED and ACK it switches to the baud rate
  and starts its data phase ``data_start_ms`` later (after the HAT's own switch, which comes
  10 ms after its ACK). The three values are the profile's ``device_setup`` (the facts give only
  the HAT's side; docs/EMULATOR-MODELS.md explains the choice); the constants below are used
  for a device on no port. The set-up baud is the port's own 2400, as on the firmware; a HAT
  made with ``fast_setup`` takes the profile's faster ``fast_baud`` (test suites that want it).
- Data phase: mode 0 is selected at first. SELECT (with the EXT_MODE bit 3) changes the mode,
  and the device answers with data at once. A CMD WRITE ``0x20+n, i, (m<<4)|d ...`` configures
  combi index i (n = 0 removes it); while mode i is selected and combi i is configured, the DATA
  message carries those datasets packed back to back (each in its mode's type size). A DATA
  message from the HAT (write1) is stored as that mode's output value and echoed when the mode
  is read.
- When to send: whenever the selected mode's payload changes (sampled every ``sample_ms``) and
  once after every NACK keep-alive. ``@rate P MS`` (``set_rate``) replaces that with one message
  every MS ms and nothing else (``MS = 0`` restores the default), which lets scenarios starve the
  HAT's 500 ms watchdog.
- ``@data P M HH..`` (``world_data``): one DATA message for mode M right away, and mode M keeps
  those bytes until ``@data P M auto``.

Idle milliseconds (see ``emulator/ports/port.py``): :meth:`ActiveDevice.next_due` tells the port when
the device next has something to do. A sample that cannot find a new payload is not run at all:
the payload depends only on the device's own world (changed in :meth:`ActiveDevice.step`, which
then marks it stale) and on what reaches it through the port (which calls
:meth:`ActiveDevice.inputs_changed`); the sampling instants it skips are made up by arithmetic.
"""
from __future__ import annotations

import math
import random
import struct
from typing import Dict, List, Optional, Sequence

from ..ports import lpf2
from ..services import DevicePort
from .setup_stream import setup_messages

__all__ = ["ActiveDevice", "SETUP_START_MS", "DATA_START_MS", "SETUP_BAUD", "pack_values",
           "setup_timing"]

SETUP_BAUD = 2400        # the rate the HAT listens at until the handshake (fb-active)
FAST_SETUP_BAUD = 9600   # only when asked (``fast_setup``)
SETUP_START_MS = 110     # > the HAT's 100 ms receive-sync gap (FIRMWARE-BEHAVIOUR.md#fb-lpf2-receive)
DATA_START_MS = 20       # after the HAT's ACK; the HAT switches its baud rate at +10 ms (#fb-active)


def setup_timing(features: Optional[dict], fast: bool = False) -> tuple[int, int, int]:
    """(start_ms, baud, data_start_ms) of the device side of the set-up: the profile's
    ``device_setup``, else the module's constants; ``fast``: its ``fast_baud``."""
    given = (features or {}).get("device_setup") or {}
    baud = (int(given.get("fast_baud", FAST_SETUP_BAUD)) if fast
            else int(given.get("baud", SETUP_BAUD)))
    return (int(given.get("start_ms", SETUP_START_MS)), baud,
            int(given.get("data_start_ms", DATA_START_MS)))

_PACK = {0: ("<b", 0xFF, 1), 1: ("<h", 0xFFFF, 2), 2: ("<i", 0xFFFFFFFF, 4)}


def _pack_one(value: float, ftype: int) -> bytes:
    if ftype == 3:
        return struct.pack("<f", float(value))
    fmt, mask, size = _PACK.get(ftype, _PACK[0])
    v = int(value) & mask                         # wrap like a C cast to the field width
    return v.to_bytes(size, "little", signed=False)


def _unpack_one(data: bytes, ftype: int) -> float:
    if ftype == 3:
        return struct.unpack("<f", (data + bytes(4))[:4])[0]
    fmt, _, size = _PACK.get(ftype, _PACK[0])
    return struct.unpack(fmt, (data + bytes(size))[:size])[0]


def pack_values(values: Sequence[float], ftype: int) -> bytes:
    """Values as the device puts them on the wire (little-endian, type 0/1/2 int, 3 float)."""
    return b"".join(_pack_one(v, ftype) for v in values)


class ActiveDevice:
    """One active device. Subclasses override :meth:`model_values` (and maybe :meth:`step`)."""

    kind = "active"
    sample_ms = 10           # how often the device re-reads its sensors for on-change data

    def __init__(self, entry: dict, rng: Optional[random.Random] = None):
        self.entry = entry
        self.type_id: int = entry["type_id"]
        self.rng = rng or random.Random(0)
        self.modes: Dict[int, dict] = {m["index"]: m for m in entry["modes"]}
        self.port: Optional[DevicePort] = None   # the port it is plugged into (set by the port)
        self.dead = False             # stopped talking for good (until unplugged)
        self.world: Dict[int, bytes] = {}
        self.rate_ms = 0
        self._reset_link()

    # -- link state ------------------------------------------------------------------------
    def _timing(self) -> tuple[int, int, int]:
        port = self.port
        if port is None:
            return setup_timing(None)
        return setup_timing(port.hat.profile.features, bool(getattr(port.hat, "fast_setup", False)))

    def _reset_link(self) -> None:
        self.state = "idle"           # idle -> setup -> wait_ack -> data_wait -> data
        self.baud = self._timing()[1]
        self.mode = 0
        self._ext = 0
        self.combis: Dict[int, List[tuple[int, int]]] = {}
        self.written: Dict[int, bytes] = {}
        self._setup_at: Optional[int] = None
        self._speed_seen = False
        self._data_at: Optional[int] = None
        self._nack = False
        self._force = False
        self._last_payload: Optional[bytes] = None
        self._last_sample = -(10 ** 9)
        self._stale = True            # the payload may differ from the one last sampled
        self._lazy_grid = False       # the port sleeps through sampling instants (next_due)
        self._last_rate_send = -(10 ** 9)
        self._pending_world: List[tuple[int, bytes]] = []

    def reset_link(self) -> None:
        """The HAT dropped the connection: start over (a LEGO device re-syncs by itself)."""
        self._reset_link()

    @property
    def talking(self) -> bool:
        """True while the device is plugged in and alive (it holds the HAT's RX line for detection)."""
        return not self.dead

    def begin_setup(self, now: int) -> None:
        """The HAT saw the device and turned its UART on: send the setup stream soon."""
        if self.dead:
            return
        self._reset_link()
        self.state = "setup"
        self._setup_at = now + self._timing()[0]

    # -- messages from the HAT ---------------------------------------------------------------
    def receive(self, msg: lpf2.Message, now: int) -> None:
        if self.dead:
            return
        if msg.header == lpf2.ACK and msg.msg_class == lpf2.SYS:
            if self.state == "wait_ack" and self._speed_seen:
                self.baud = self.entry["baud"]
                self._data_at = now + self._timing()[2]
                self.state = "data_wait"
            return
        if msg.header == lpf2.NACK:
            self._nack = True
            return
        if not msg.ok:
            return                    # a device ignores messages with a bad checksum
        cls, code = msg.msg_class, msg.code
        if cls == lpf2.CMD:
            if code == lpf2.CMD_SPEED:
                self._speed_seen = True
            elif code == lpf2.CMD_EXT_MODE and msg.payload:
                self._ext = msg.payload[0] & 8
            elif code == lpf2.CMD_SELECT and msg.payload:
                mode = self._ext + (msg.payload[0] & 7)
                # A device ignores a SELECT of a mode it does not have (model choice: the facts
                # are silent; going mute would make the HAT time the device out).
                if mode in self.modes or mode in self.combis:
                    self.mode = mode
                self._force = True
            elif code == lpf2.CMD_WRITE and msg.payload:
                self._combi_write(msg.payload)
        elif cls == lpf2.DATA:
            mode = msg.code
            info = self.modes.get(mode)
            if info is not None:
                self.written[mode] = bytes(msg.payload[: info["data_bytes"]])
                self._force = True

    def _combi_write(self, payload: bytes) -> None:
        if payload[0] & 0xE0 != 0x20 or len(payload) < 2:
            return
        n, index = payload[0] & 0x1F, payload[1]
        pairs = [(b >> 4, b & 0x0F) for b in payload[2:2 + n]]
        if pairs:
            self.combis[index] = pairs
        else:
            self.combis.pop(index, None)
        self._force = True

    def port_duty(self):
        """What the HAT's motor driver applies to this device's port (+-255, "coast"), with a
        latched motor fault seen as coast (``PortController.motor_output``)."""
        port = self.port
        if port is None:
            return "coast"
        return port.hat.controllers[port.index].motor_output()

    # -- values ------------------------------------------------------------------------------
    def model_values(self, mode: int, now: int) -> List[float]:
        """The model's own values for ``mode`` (format count entries). Subclasses override.
        They may change only in :meth:`step` (which then sets ``_stale``) or with what reaches
        the device through its port (drive, messages, world actions): samples rely on it."""
        return [0] * self.modes[mode]["format"]["count"]

    def mode_payload(self, mode: int, now: int) -> bytes:
        """What the device reports for a plain mode: world override, last write, else the model."""
        if mode in self.world:
            return self.world[mode]
        if mode in self.written:
            return self.written[mode]
        info = self.modes[mode]
        return pack_values(self.model_values(mode, now), info["format"]["type"])

    def _dataset(self, mode: int, dataset: int, now: int) -> bytes:
        info = self.modes.get(mode)
        if info is None:
            return b""
        ftype = info["format"]["type"]
        size = 4 if ftype >= 2 else ftype + 1
        payload = self.mode_payload(mode, now)
        return (payload[dataset * size:(dataset + 1) * size] + bytes(size))[:size]

    def current_payload(self, now: int) -> Optional[bytes]:
        """The payload of the DATA message for the selected mode (None: nothing to report)."""
        if self.mode in self.combis:
            return b"".join(self._dataset(m, d, now) for m, d in self.combis[self.mode])
        if self.mode not in self.modes:
            return None
        return self.mode_payload(self.mode, now)

    def _data_message(self, mode: int, payload: bytes) -> bytes:
        return lpf2.device_message(lpf2.DATA, mode & 7, payload[: 32] or b"\x00")

    # -- world actions ---------------------------------------------------------------------
    def world_data(self, mode: int, payload: Optional[bytes]) -> None:
        """``@data P M HH..`` (payload) or ``@data P M auto`` (None)."""
        if mode not in self.modes:
            raise ValueError(f"device 0x{self.type_id:02X} has no mode {mode} "
                             f"(modes {sorted(self.modes)})")
        if payload is None:
            self.world.pop(mode, None)
            return
        if not 1 <= len(payload) <= 32:
            raise ValueError(f"@data payload must be 1..32 bytes, got {len(payload)}")
        self.world[mode] = bytes(payload)
        self._pending_world.append((mode, bytes(payload)))

    def set_rate(self, ms: int) -> None:
        """``@rate P MS``: send every MS ms and nothing else; 0 = back to on-change + keep-alive."""
        if ms < 0:
            raise ValueError(f"@rate must be >= 0 ms, got {ms}")
        self.rate_ms = int(ms)

    # -- time --------------------------------------------------------------------------------
    def step(self, now: int) -> None:
        """Advance the device's own world by one millisecond (motors run their physics)."""

    def inputs_changed(self) -> None:
        """The port passed on a change from outside (a message, a world action, a new drive):
        the next sample must look at the payload again."""
        self._stale = True

    def step_due(self, now: int) -> float:
        """The first millisecond after ``now`` in which :meth:`step` may change anything
        (subclasses with a world of their own say when; the base device has none)."""
        return math.inf

    def next_due(self, now: int) -> float:
        """The first millisecond after ``now`` in which :meth:`tick` may send or change state,
        as things stand (the port wakes up for anything that changes them from outside)."""
        due = self.step_due(now)
        if self.dead:
            return due
        state = self.state
        if state == "data":
            if self._pending_world or self._force or self._nack:
                return now + 1
            if self.rate_ms > 0:
                return min(due, self._last_rate_send + self.rate_ms)
            if self._stale:
                return min(due, self._last_sample + self.sample_ms)
            # Samples before a change would find the payload they found last time: sleep
            # through them; tick() moves the sampling instant on as they would have.
            self._lazy_grid = True
            return due
        if state == "setup" and self._setup_at is not None:
            return min(due, self._setup_at)
        if state == "data_wait" and self._data_at is not None:
            return min(due, self._data_at)
        return due

    def next_send(self, now: int) -> float:
        """The first millisecond after ``now`` at which :meth:`tick` may *send*: a world that
        lets the device's own physics catch up in one step (sil/port_world.py; the drive is constant
        between two of its looks at the firmware) need not tick it before."""
        if self.dead or self.state != "data":
            return self.next_due(now)
        if self._pending_world or self._force or self._nack:
            return now + 1
        if self.rate_ms > 0:
            return max(now + 1, self._last_rate_send + self.rate_ms)
        return max(now + 1, self._last_sample + self.sample_ms)

    def tick(self, now: int) -> List[bytes]:
        """Messages the device starts sending at ``now`` (the port's wire paces the bytes)."""
        if self._lazy_grid:
            self._lazy_grid = False
            # The samples due before now were skipped; each would have moved _last_sample on.
            gap = now - 1 - self._last_sample
            if gap >= self.sample_ms:
                self._last_sample += gap // self.sample_ms * self.sample_ms
        self.step(now)
        if self.dead:
            return []
        if self.state == "setup" and self._setup_at is not None and now >= self._setup_at:
            self.state = "wait_ack"
            return setup_messages(self.entry)
        if self.state == "data_wait" and self._data_at is not None and now >= self._data_at:
            self.state = "data"
            self._force = True
        if self.state != "data":
            return []
        return self._data_tick(now)

    def _data_tick(self, now: int) -> List[bytes]:
        out = [self._data_message(m, p) for m, p in self._pending_world]
        self._pending_world.clear()
        if self.rate_ms > 0:
            self._nack = self._force = False
            if now - self._last_rate_send >= self.rate_ms:
                self._last_rate_send = now
                payload = self.current_payload(now)
                if payload is not None:
                    out.append(self._data_message(self.mode, payload))
            return out
        send = self._force or self._nack
        payload = None
        if send or now - self._last_sample >= self.sample_ms:
            self._last_sample = now
            if send or self._stale:       # else: the payload of the last sample, None or sent
                self._stale = False
                payload = self.current_payload(now)
                if payload is not None and payload != self._last_payload:
                    send = True
        if send:
            if payload is None:
                payload = self.current_payload(now)
            self._nack = self._force = False
            if payload is not None:
                self._last_payload = payload
                out.append(self._data_message(self.mode, payload))
        return out

"""The emulator's Python API: one emulated HAT in virtual time.

    emu = Emulator(firmware="R7")          # default device layout of the script format
    emu.boot()                             # start-up done and the layout's devices established
    emu.write(b"version\\r"); emu.advance(5); print(emu.read())
    emu.world("@plug 3 0x30")              # world actions as written in a scenario script

Nothing here reads the wall clock: time moves only through :meth:`advance`. Output is
readable as soon as the firmware writes it unless ``baud`` is given (then both directions
of the serial link move at the wire rate, FIRMWARE-BEHAVIOUR.md#fb-uart).
"""
from __future__ import annotations

from typing import Any, Callable, Dict, List, Mapping, Optional, Union

from ..protocol.devices import DEFAULT_LAYOUT, format_device_spec, parse_device_spec
from ..protocol.profiles import Profile, get_profile, load_profiles
from ..serving.reset_pins import HeldInReset
from .bootloader import Bootloader, bootloader_checksum
from .command_uart import Uart
from .hang import HangTrigger, Hung
from .hat import DEFAULT_ADC, Hat
from .world_actions import WorldError, perform_line

__all__ = ["Emulator", "WorldError", "BOOT_LIMIT_MS", "DEFAULT_ADC"]

# boot() gives up (with an error naming the ports) if the layout is not up by then.
BOOT_LIMIT_MS = 20000
BOOTLOADER_RING = 4096     # FIRMWARE-BEHAVIOUR.md#fb-bootloader: the bootloader's RX/TX rings
# boot() looks at the layout every 10 ms, as the firmware in the loop's boot does (sil/hat.py).
BOOT_STEP_MS = 10
_BYTE_US = 10 * 1_000_000 / 115200      # one byte on the HAT's 115200-baud wire (8N1)


class _WireClock:
    """When what the firmware wrote has crossed a 115200-baud wire, paced or not here: the
    host's view of the start-up that scenario time 0 is judged by."""

    def __init__(self, now: int):
        self.free_us = float(now * 1000)

    def sent(self, now: int, count: int) -> None:
        if count > 0:
            self.free_us = max(self.free_us, now * 1000.0) + count * _BYTE_US

    def idle(self, now: int) -> bool:
        return self.free_us <= now * 1000.0

DeviceSpec = Union[None, str, tuple]
Event = Dict[str, Any]


def _layout(devices: Optional[Mapping[int, DeviceSpec]]) -> Dict[int, Optional[tuple]]:
    layout = dict(DEFAULT_LAYOUT)
    for port, spec in (devices or {}).items():
        p = int(port)
        if not 0 <= p <= 3:
            raise ValueError(f"device port must be 0..3, got {port!r}")
        layout[p] = parse_device_spec(spec) if isinstance(spec, str) else spec
    return layout


class Emulator:
    """One emulated Build HAT (firmware or bootloader) driven in virtual milliseconds."""

    def __init__(self, firmware: Union[str, int, None] = None,
                 devices: Optional[Mapping[int, DeviceSpec]] = None,
                 version_string: Optional[str] = None, bootloader: bool = False, seed: int = 0,
                 baud: Optional[int] = None, bootloader_key: Union[bytes, str, None] = None,
                 record_events: bool = True, hang_after: Optional[int] = None,
                 fast_setup: bool = False):
        self.profile: Profile = get_profile(firmware)
        # Fault injection (emulator/hang.py): the firmware hangs after the host's Nth line, once.
        self._hang = HangTrigger(hang_after)
        self._signature: Optional[bytes] = None     # the running image's, kept over a reset
        self.devices = _layout(devices)
        self.version_string = version_string
        self.seed = seed
        self.fast_setup = fast_setup    # devices set up faster than the port's 2400 baud
        self.bootloader_key = bootloader_key
        self.uart = Uart(baud=baud)
        # Every event is kept in ``events`` unless record_events is False (long real-time runs,
        # where only the on_event callbacks see them and memory must stay flat).
        self.events: List[Event] = []
        self.record_events = record_events
        self._callbacks: List[Callable[[Event], None]] = []
        self._now = 0
        self.machine: Any = None
        if bootloader:
            self._start_bootloader()
        else:
            self._start_firmware(self.profile)

    # -- machines --------------------------------------------------------------------------
    def _sink(self, kind: str, t: int, fields: Dict[str, Any]) -> None:
        event = {"t": t, "dir": kind}
        event.update(fields)
        if self.record_events:
            self.events.append(event)
        for cb in list(self._callbacks):
            cb(event)

    def _start_firmware(self, profile: Profile, signature: Optional[bytes] = None) -> None:
        self.profile = profile
        self._signature = signature
        self.uart.resize(8192, 8192)
        self.machine = Hat(profile, self.uart, version_string=self.version_string,
                           signature=signature, event_sink=self._sink, now=self._now, seed=self.seed,
                           fast_setup=self.fast_setup)
        for port, spec in sorted(self.devices.items()):
            if spec is not None:
                perform_line(self.machine, f"@plug {port} {format_device_spec(spec)}")

    def _start_bootloader(self) -> None:
        self.uart.resize(BOOTLOADER_RING, BOOTLOADER_RING)
        self.machine = Bootloader(self.uart, now=self._now, event_sink=self._sink,
                                         reboot=self._reboot_into, key=self.bootloader_key)

    def _reboot_into(self, image: bytes, signature: Optional[bytes]) -> None:
        """The bootloader jumps to an uploaded, verified image: run the release it is."""
        self._now = self.machine.now        # called from inside the bootloader's tick
        checksum = bootloader_checksum(image)
        match = [p for p in load_profiles().values() if p.image_checksum == checksum]
        if match:
            self._start_firmware(match[0], signature=signature)
            return
        self._start_firmware(get_profile(None), signature=signature)
        self._sink("note", self._now, {"text": f"uploaded image (checksum {checksum}) is no known "
                                               f"release; running {self.profile.name}"})

    @property
    def hat(self) -> Optional[Hat]:
        """The running firmware, or None while the bootloader runs."""
        return self.machine if isinstance(self.machine, Hat) else None

    @property
    def in_bootloader(self) -> bool:
        return not isinstance(self.machine, Hat)

    # -- bytes and time --------------------------------------------------------------------
    @property
    def now(self) -> int:
        return self._now

    def write(self, data: bytes) -> None:
        """Bytes from the host; the firmware handles them at once (before the next tick).

        Without a baud rate the wire is infinitely fast but the firmware keeps up with it, so
        the bytes go in ring-sized pieces with the firmware reading between them (a 50 KB
        bootloader upload arrives whole). During the start-up nobody reads the ring and what
        does not fit is dropped, as on the HAT."""
        data = bytes(data)
        cut = self._hang.split(data) if self.hat is not None else None
        if cut is not None:
            self.write(data[:cut])
            self.hang()
            self.uart.host_write(data[cut:])    # into the ring of a firmware that no longer reads
            return
        if self.uart.baud is not None:
            self.uart.host_write(data)
            self.machine.poll()
            return
        step = max(1, self.uart.rx_size)
        for i in range(0, len(data), step):
            self.uart.host_write(data[i:i + step])
            self.machine.poll()

    def host_room(self) -> Optional[int]:
        """Host bytes the wire takes now (None: any number, no baud rate); a real-time runner reads no
        more than this from its link, so the host feels the wire's pace (back-pressure)."""
        return self.uart.host_room()

    def read(self) -> bytes:
        """Every output byte not yet read."""
        return self.uart.host_read()

    def advance(self, ms: int) -> None:
        """Let ``ms`` milliseconds of virtual time pass."""
        if ms < 0:
            raise ValueError(f"cannot advance by a negative time ({ms} ms)")
        end = self._now + int(ms)
        while self._now < end:
            machine = self.machine
            if isinstance(machine, Hat):
                machine.advance(end - self._now)   # skips the milliseconds in which nothing is due
            else:
                machine.tick()                     # the bootloader (it may boot a Hat)
            self._now = self.machine.now

    def advance_until_output(self, ms: int) -> int:
        """Let at most ``ms`` milliseconds pass, stopping after the first one that gave the host
        output (idle milliseconds are skipped as in :meth:`advance`). Returns the time spent:
        a virtual-time reader waits for output this way without stepping every millisecond."""
        start = self._now
        end = start + max(0, int(ms))
        while self._now < end and not self.uart.host_pending():
            machine = self.machine
            if isinstance(machine, Hat):
                # Hat.advance up to the first due ms, inlined: this loop runs once per ticked ms.
                due = machine.idle_until()
                if due > machine.now + 1:
                    machine.now = int(min(due, end)) - 1   # the ticks before `due` only count time
                machine.tick()
            else:
                machine.tick()                      # the bootloader (it may boot a Hat)
            self._now = self.machine.now
        return self._now - start

    def step(self) -> None:
        """One millisecond."""
        self.machine.tick()
        self._now = self.machine.now

    def idle_until(self) -> float:
        """The first virtual millisecond whose tick may do anything (output, events, state):
        the ticks before it only count time, so a real-time runner may sleep until then."""
        hat = self.hat
        return hat.idle_until() if hat is not None else self._now + 1

    def on_event(self, callback: Callable[[Event], None]) -> None:
        """Call ``callback(event)`` for every transcript event (dev, devrx, pwm, led, note)."""
        self._callbacks.append(callback)

    def boot(self, limit_ms: int = BOOT_LIMIT_MS, each_ms: Optional[Callable[[], None]] = None) -> int:
        """Run the start-up until the layout's devices are established; returns the time taken.
        ``each_ms`` is called after every millisecond (e.g. to record output with its time).

        Where it ends is scenario time 0 on every target (docs/EMULATOR-MODELS.md "Scenario time
        0"): the first 10 ms step from the start at which the layout's connect lines have
        crossed a 115200-baud wire to the host, as a firmware in the loop's boot judges it
        (sil/hat.py). An unpowered LED matrix's grace (``matrix_power_grace_ms``) restarts
        then, once, as it does there."""
        start = self._now
        wire = _WireClock(self._now)
        # A port counts once its device has been up: a device that fails again during the
        # start-up (an unpowered LED matrix's grace running out while a motor still sets up)
        # has printed its connect line, which is what the firmware in the loop's boot sees.
        up = set(p for p in range(4) if p not in self._unsettled())
        while not (self.hat is None or (self.hat.ready and up >= self._layout_ports())
                   and wire.idle(self._now)):
            if self._now - start >= limit_ms:
                raise RuntimeError(f"start-up not finished after {limit_ms} ms "
                                   f"(ports not settled: {sorted(self._layout_ports() - up)})")
            for _ in range(BOOT_STEP_MS):
                written = self.hat.tx_written if self.hat is not None else 0
                self.step()
                if self.hat is not None:
                    wire.sent(self._now, self.hat.tx_written - written)
                    up.update(p for p in range(4) if p not in self._unsettled())
                if each_ms is not None:
                    each_ms()
        self._restart_power_grace()
        return self._now - start

    def _restart_power_grace(self) -> None:
        """A booted HAT is what a host finds when it opens the port: a device that needs power
        from the host (the LED matrix) counts its grace from then, not from its set-up."""
        hat = self.hat
        if hat is None:
            return
        for port in hat.ports:
            restart = getattr(port.device, "restart_grace", None)
            if restart is not None:
                restart(self._now)

    def settled(self) -> bool:
        """Start-up finished and every port with a device has it connected/established."""
        hat = self.hat
        if hat is None:
            return True
        return hat.ready and not self._unsettled()

    def _layout_ports(self) -> set:
        return {p for p, spec in self.devices.items() if spec is not None}

    def _unsettled(self) -> List[int]:
        hat = self.hat
        if hat is None:
            return []
        return [p.index for p in hat.ports if not getattr(p, "settled", True)]

    # -- world -----------------------------------------------------------------------------
    def world(self, line: str) -> str:
        """A world action as written in a script (``@plug 1 0x30``), or ``@reset [bootloader]``,
        ``@time``, ``@firmware``, ``@hang`` (fault injection). Returns ``ok`` / ``ok <value>``;
        raises WorldError."""
        words = line.split()
        if not words:
            raise WorldError("empty action")
        head = words[0]
        if head == "@reset":
            if words[1:] not in ([], ["bootloader"]):
                raise WorldError("@reset takes nothing or 'bootloader'")
            self.reset(bootloader=bool(words[1:]))
            return "ok"
        if head == "@hang":
            if words[1:]:
                raise WorldError("@hang takes nothing")
            self.hang()
            return "ok"
        if head == "@time":
            return f"ok {self._now}"
        if head == "@firmware":
            if isinstance(self.machine, Hung):
                return "ok hung"
            if isinstance(self.machine, HeldInReset):
                return "ok reset"
            if self.in_bootloader:
                return "ok bootloader"
            return f"ok {self.machine.version_string}"
        if self.hat is None:
            raise WorldError(f"{head}: the bootloader is running (no ports)")
        perform_line(self.hat, line)
        if head == "@plug":
            self.devices[int(words[1])] = parse_device_spec(" ".join(words[2:]))
        elif head == "@unplug":
            self.devices[int(words[1])] = None
        return "ok"

    def hold_reset(self) -> None:
        """RESET held low (serving/reset_pins.py): the chip stops until :meth:`reset` releases it."""
        self.machine = HeldInReset(self.uart, now=self._now)

    def arm_hang(self, lines: int) -> None:
        """Fault injection: hang once, after the host's next ``lines`` lines."""
        self._hang = HangTrigger(lines)

    def hang(self) -> None:
        """The firmware stops (emulator/hang.py) until a reset."""
        self.note("the firmware hangs (fault injection): nothing is read or printed until a reset")
        self.machine = Hung(self.uart, now=self._now)

    def note(self, text: str) -> None:
        """A transcript ``note`` event at the current time (a remark by the tool)."""
        self._sink("note", self._now, {"text": text})

    def reset(self, bootloader: bool = False) -> None:
        """Pulse the HAT's reset line: firmware restarts (or the bootloader, if asked)."""
        if bootloader:
            self._start_bootloader()
        else:
            self._start_firmware(self.profile, signature=self._signature)

"""A firmware in the loop as the harness drives a HAT model: bytes in, bytes out, virtual ms.

:class:`SilHat` has the interface of the emulator's ``Emulator`` that the in-process target
and the real-time runners use (``now``, ``write``, ``read``, ``advance``,
``advance_until_output``, ``step``, ``boot``, ``world``, ``on_event``, ``reset``), but the HAT
behind it is a firmware tree built for the host (``sil/build.py``) running in a child process
(``sil/process.py``), with the emulator's device models around it (``sil/port_world.py``,
:attr:`SilHat.outside`).

Time: the firmware's clock is virtual nanoseconds; the harness sees milliseconds. Nothing
reads the wall clock except the hang watchdog of the child process.
A firmware that crashes or exits becomes a dead HAT: what it sent before stays readable,
then :meth:`read` raises :class:`FirmwareDied` once with its report, and the HAT stays silent.
"""
from __future__ import annotations

import copy
import re
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

from ..emulator.command_uart import WIRE_AHEAD, WIRE_AHEAD_MS
from ..emulator.world_actions import WorldError, perform_line
from ..protocol.devices import DEFAULT_LAYOUT, parse_device_spec
from .frames import NS_PER_MS, FrameType, encode
from .port_world import SilWorld
from .process import FirmwareDied, FirmwareProcess
from .sanitizer_reports import FirmwareReport

__all__ = ["SilHat", "FirmwareDied", "BOOT_LIMIT_MS"]

# A run stops at the first block boundary past its limit: a few blocks (80 ns each) at most.
STOP_OVERSHOOT_NS = 1_000

BOOT_LIMIT_MS = 20000
# The command port's byte time at 115200 baud 8N1 (docs/FIRMWARE-BEHAVIOUR.md#fb-uart), as the
# stand-in reckons it (whole ns): host bytes reach the firmware no faster than this.
HOST_BYTE_NS = 10 * 1_000_000_000 // 115200
# Host bytes taken ahead of the wire: as many as it carries in WIRE_AHEAD_MS, the emulator's figure
# (emulator/command_uart.py), so a real-time runner that wakes a little late still keeps the wire busy.
HOST_AHEAD = max(WIRE_AHEAD, WIRE_AHEAD_MS * 1_000_000 // HOST_BYTE_NS)
SEEN_LIMIT = 256 * 1024     # output since power-on kept for settled(): the start-up is a few KB
_VERSION_LINE = re.compile(rb"Firmware version: ([^\r\n]*)\r\n")
VERSION_WAIT_MS = 2000      # HAT time for a copy to answer `version`
_CONNECTED = re.compile(rb"P([0-3]): (connected to passive ID|established serial communication)")
Event = Dict[str, Any]


class SilHat:
    #: Arguments of the program (the rp2040: target's is Node.js with its runner and image).
    program_args: Sequence[str] = ()

    def __init__(self, program: str, devices: Optional[Mapping[int, Any]] = None, seed: int = 0,
                 features: Optional[Mapping[str, Any]] = None, env: Optional[dict] = None,
                 signature: Optional[bytes] = None, record_events: bool = True):
        layout: Dict[int, Any] = dict(DEFAULT_LAYOUT)
        for port, spec in (devices or {}).items():
            if not 0 <= int(port) <= 3:
                raise ValueError(f"device port must be 0..3, got {port!r}")
            layout[int(port)] = parse_device_spec(spec) if isinstance(spec, str) else spec
        self.program, self.seed, self.features, self.env = program, seed, features, env
        self.signature = signature        # what the bootloader leaves in RAM for `signature`
        self.devices = layout
        self.events: List[Event] = []
        # Every event is kept in ``events`` unless record_events is False (a long real-time
        # serve, where only the on_event callbacks see them and memory must stay flat).
        self.record_events = record_events
        self._callbacks: List[Callable[[Event], None]] = []
        self._out = bytearray()
        self._seen = bytearray()          # output since power-on, for boot()'s connect lines
        self._base_ns = 0                 # virtual time at the current process's power-on
        self._now_ns = 0
        self._host_free_ns = 0            # when the last host byte written will have crossed the wire
        self.died: Optional[FirmwareDied] = None
        self._version: Optional[str] = None   # what `version` prints, once asked (reported_version)
        self._died_unreported = False
        self.hung = False
        # Sanitizer reports the firmware went on after, and the one it died of: taken by
        # whoever judges what the HAT is doing (take_reports).
        self.reports: List[FirmwareReport] = []
        self._start()

    # -- the child process ---------------------------------------------------------------
    def _start(self) -> None:
        self._base_ns = self._now_ns
        self._host_free_ns = self._now_ns     # a new process: nothing of the host's is on its wire
        self._seen.clear()
        self.outside = SilWorld(self.devices, seed=self.seed, features=self.features, event=self._event)
        self.outside.base_ns = self._base_ns
        if self.signature:
            self.outside.send(encode(FrameType.SIGNATURE, 0, bytes(self.signature)[:64]))
        self.died, self.hung = None, False
        try:
            self.proc: Optional[FirmwareProcess] = FirmwareProcess(self.program, env=self.env,
                                                                   args=self.program_args)
        except FirmwareDied as exc:
            self.proc = None
            self._die(exc)

    def _die(self, exc: FirmwareDied) -> None:
        self.died = exc
        self._collect(exc)
        self._died_unreported = True
        self.note(exc.summary)
        if exc.report:
            self._sink("crash", self.now, {"report": exc.report})
        frames = getattr(exc, "frames", None) or []
        for frame in frames:
            self._take(frame)

    def _run(self, end_ns: int, stop_on_output: bool, once: bool = False) -> None:
        """Run firmware and world up to ``end_ns`` (or the first output, if asked; or the
        firmware's first stop, ``once``)."""
        while self._now_ns < end_ns:
            if self.proc is None or self.died is not None or self.hung:
                self._now_ns = end_ns        # a dead or hung HAT: time passes, nothing happens
                self.outside.take_outbox()
                return
            due = self.outside.next_due()
            limit = end_ns if due == float("inf") else min(end_ns, int(due * NS_PER_MS))
            limit = max(limit, self._now_ns + 1)
            try:
                frames = self.proc.run(limit - self._base_ns, self.outside.take_outbox(),
                                       yield_on_host_idle=stop_on_output)
            except FirmwareDied as exc:
                self._die(exc)
                continue
            self._now_ns = self._base_ns + self.proc.now
            if self.proc.reports:
                self._collect()
            for frame in frames:
                self._take(frame)
            self.outside.tick_due(self.now, self._now_ns / NS_PER_MS)
            if (stop_on_output and self._out) or once:
                return

    def _take(self, frame) -> None:
        if frame.kind == FrameType.TO_HOST:
            self._out += frame.payload
            if len(self._seen) < SEEN_LIMIT:      # the start-up's lines, for settled(); no more
                self._seen += frame.payload
        else:
            self.outside.from_firmware(frame._replace(t=frame.t + self._base_ns))

    def _collect(self, exc: Optional[FirmwareDied] = None) -> None:
        if self.proc is None:             # it did not start: what it said is the death's
            found = exc.findings if exc is not None else []
        else:
            found = self.proc.take_reports()
        for report in found:
            self.reports.append(report)
            if not report.fatal:          # (the fatal one is in the death's own event)
                self._sink("sanitizer", self.now, {"report": report.text})

    def take_reports(self) -> List[FirmwareReport]:
        """The firmware's reports since the last call, in order (a death's last)."""
        out, self.reports = self.reports, []
        return out

    # -- events ----------------------------------------------------------------------------
    def _event(self, kind: str, t: int, fields: Dict[str, Any]) -> None:
        self._sink(kind, t, fields)

    def _sink(self, kind: str, t: int, fields: Dict[str, Any]) -> None:
        event: Event = {"t": int(t), "dir": kind}
        event.update(fields)
        if self.record_events:
            self.events.append(event)
        for cb in list(self._callbacks):
            cb(event)

    def on_event(self, callback: Callable[[Event], None]) -> None:
        self._callbacks.append(callback)

    def note(self, text: str) -> None:
        self._sink("note", self.now, {"text": text})

    # -- the HatModel interface ------------------------------------------------------------
    @property
    def now(self) -> int:
        return self._now_ns // NS_PER_MS

    @property
    def power_on_ms(self) -> int:
        """When the running firmware process was powered on (a reset starts a new one), HAT ms."""
        return self._base_ns // NS_PER_MS

    def write(self, data: bytes) -> None:
        if self.proc is not None and self.died is None and not self.hung:
            for i in range(0, len(data), 4096):
                start = self._now_ns - self._base_ns
                self.outside.send(encode(FrameType.HOST_BYTES, start, bytes(data[i:i + 4096])))
            # The stand-in queues them on the command port's wire, one byte time each (sil/README.md).
            self._host_free_ns = max(self._host_free_ns, self._now_ns) + len(data) * HOST_BYTE_NS

    def host_room(self) -> Optional[int]:
        """Host bytes the wire takes now: a real-time runner reads no more than this from its link, so
        a host that writes faster than 115200 baud is pushed back as a UART pushes it back, and the
        firmware's own receive ring meets the host's bytes at the wire's rate (issue 39)."""
        queued = -(-max(0, self._host_free_ns - self._now_ns) // HOST_BYTE_NS)
        return max(0, HOST_AHEAD - queued)

    def read(self) -> bytes:
        out = bytes(self._out)
        self._out.clear()
        if not out and self._died_unreported and self.died is not None:
            self._died_unreported = False
            raise self.died
        return out

    def advance(self, ms: int) -> None:
        if ms < 0:
            raise ValueError(f"cannot advance by a negative time ({ms} ms)")
        self._run(self._now_ns + int(ms) * NS_PER_MS, stop_on_output=False)

    def advance_until_output(self, ms: int) -> int:
        start = self.now
        if not self._out:
            self._run(self._now_ns + max(0, int(ms)) * NS_PER_MS, stop_on_output=True)
        return self.now - start

    def settle(self, min_ms: int, max_ms: int) -> int:
        """Let HAT time pass until the command port is at rest (nothing leaving, nothing
        arriving: a TX ring drained), at least ``min_ms`` and at most ``max_ms``; returns the
        whole ms that passed. The firmware stops when its transmitter falls idle, so this costs
        no more stops than :meth:`advance`."""
        start = self._now_ns
        self.advance(min_ms)
        end = start + max(min_ms, max_ms) * NS_PER_MS
        while self._now_ns < end and self.proc is not None and not self.proc.host_quiet:
            if self.died is not None or self.hung:
                break
            self._run(end, stop_on_output=True, once=True)
        # (whole ms, as a script's @wait says; the firmware stops a few blocks past a limit, which
        # does not make another millisecond)
        ms = min(-(-(self._now_ns - start - STOP_OVERSHOOT_NS) // NS_PER_MS), max(min_ms, max_ms))
        self._run(start + ms * NS_PER_MS, stop_on_output=False)
        return ms

    def step(self) -> None:
        self.advance(1)

    def idle_until(self) -> float:
        return self.now + 1

    def settled(self) -> bool:
        if b"Done initialising ports" not in self._seen:
            return False
        up = {int(m.group(1)) for m in _CONNECTED.finditer(bytes(self._seen))}
        return all(spec is None or port in up for port, spec in self.devices.items())

    def boot(self, limit_ms: int = BOOT_LIMIT_MS) -> int:
        start = self.now
        while not self.settled():
            if self.died is not None:
                raise RuntimeError(f"start-up failed: {self.died.summary}")
            if self.now - start >= limit_ms:
                # The firmware runs but never printed the lines a settled HAT prints: not a dead
                # target. Whoever talks to it next judges what it does print (a changed
                # `established` line is a failing case, not a firmware that did not boot).
                self.note(f"start-up not recognised after {limit_ms} ms: no 'Done initialising ports' "
                          f"and the layout's connect lines")
                break
            self.advance(10)
        self.outside.restart_grace(self.now)
        return self.now - start

    # -- world actions -----------------------------------------------------------------------
    def world(self, line: str) -> str:
        """A world action as written in a script, or ``@reset``, ``@hang``, ``@time``, ``@firmware``."""
        words = line.split()
        if not words:
            raise WorldError("empty action")
        head = words[0]
        if head == "@reset":
            if words[1:] == ["bootloader"]:
                raise WorldError("@reset bootloader: a firmware tree's bootloader is not modelled "
                                 "(the sil: target runs the firmware only)")
            if words[1:]:
                raise WorldError("@reset takes nothing here")
            self.reset()
            return "ok"
        if head == "@hang":
            self.hung = True
            self.note("the firmware hangs (fault injection): nothing is read or printed until a reset")
            return "ok"
        if head == "@time":
            return f"ok {self.now}"
        if head == "@firmware":
            if self.died is not None:
                return "ok dead"
            return "ok hung" if self.hung else f"ok {self.reported_version()}"
        if head == "@portfault" and len(words) == 3 and words[1] == "1":
            # A pulse starts (and so ends) half-way through a millisecond: the firmware counts
            # the deglitch in whole ms (fb-power-faults), so an edge a few instructions past a
            # millisecond's start would make a pulse's length count one ms more or less.
            self._run((self._now_ns // NS_PER_MS) * NS_PER_MS + NS_PER_MS + NS_PER_MS // 2,
                      stop_on_output=False)
        self.outside.catch_up(self.now)        # the shafts move up to the action first
        self.outside.now_ms = max(self.outside.now_ms, self.now)
        self.outside.exact_ms = self._now_ns / NS_PER_MS
        perform_line(self.outside, line)
        if head == "@plug":
            self.devices[int(words[1])] = parse_device_spec(" ".join(words[2:]))
        elif head == "@unplug":
            self.devices[int(words[1])] = None
        return "ok"

    def reported_version(self) -> str:
        """What the firmware prints after ``Firmware version: `` (``@firmware``, as the emulator answers
        it). Asked of a copy of this HAT, so the host's session sees nothing of it; learned once."""
        if self._version is None:
            dup = self.copy()
            try:
                if not dup.settled():
                    dup.boot()
                dup.read()
                # a CR first: a line the host left unfinished is run (in the copy) and out of the way
                dup.write(b"\rversion\r")
                got = b""
                for _ in range(VERSION_WAIT_MS // 10):
                    dup.advance(10)
                    got += dup.read()
                    found = _VERSION_LINE.search(got)
                    if found:
                        self._version = found.group(1).decode("latin-1")
                        break
            finally:
                dup.close()
        return self._version or "unknown"

    def reset(self, bootloader: bool = False) -> None:
        """Power-cycle the HAT: a new firmware process, the same layout, time goes on."""
        if bootloader:
            raise WorldError("a firmware tree's bootloader is not modelled")
        self.close()
        # Power comes back on a whole HAT millisecond, as at the first power-on: the firmware's
        # timers then keep the phase against the host's ms clock a fresh HAT has (a HAT started
        # again after a crash is the HAT every case expects: sil/README.md).
        self._now_ns = -(-self._now_ns // NS_PER_MS) * NS_PER_MS
        self._start()

    def arm_hang(self, lines: int) -> None:
        raise WorldError("hang_after is not available on a sil: target (use @hang)")

    def close(self) -> None:
        if self.proc is not None:
            self.proc.quit()
            self.proc = None

    def copy(self) -> SilHat:
        """This HAT as it is now, as a HAT of its own: the firmware process forks (its state,
        clock and pending bytes come along) and the world is copied with it."""
        if self.proc is None or self.died is not None:
            raise RuntimeError("only a running firmware can be copied")
        dup = SilHat.__new__(SilHat)
        own = ("proc", "outside", "_callbacks")
        dup.__dict__.update({k: v for k, v in self.__dict__.items() if k not in own})
        dup.events, dup._callbacks = [], []
        dup.reports = list(self.reports)      # met in the start-up this copy also went through
        dup._out, dup._seen, dup.devices = bytearray(self._out), bytearray(self._seen), dict(self.devices)
        dup.proc = self.proc.fork()
        event = self.outside._event
        self.outside._event = None             # the copy's world reports to the copy
        try:
            dup.outside = copy.deepcopy(self.outside)
        finally:
            self.outside._event = event
        dup.outside._event = dup._event
        return dup

"""Any HAT model in this process, in virtual time: the target the emulator (``inprocess:``,
emulator/targets/in_process.py), a firmware in the loop (``sil:``) and an emulated chip
(``rp2040:``) are served as.

Time: nothing here reads the wall clock. Virtual time moves only inside :meth:`read` and
:meth:`advance`. ``read(timeout)`` steps the HAT one millisecond at a time, up to
``timeout * 1000 * time_scale`` HAT milliseconds, and returns as soon as output appears. So a
wall-clock sleep (``Session.wait_ms``) does not move the HAT; call :meth:`advance` (or read with
a timeout) to let HAT time pass. ``time_scale`` defaults to 1: a read timeout is HAT seconds.

Start-up: :meth:`open` boots the HAT until the layout's devices are established. A booted HAT is
kept per (model, release, layout, seed) and copied for every later open, so opening is cheap (the
fuzzer opens one per example).

Extras for white-box tools (the fuzzer): :attr:`emulator` (the HAT model object),
:meth:`advance`, :attr:`drive_events` (transcript ``pwm``/``led`` events), :attr:`device_frames`
(transcript ``dev`` events: the frames each device received), :attr:`line_records`
(what each processed line ran, from ``hat.line_observers``).
"""
from __future__ import annotations

import copy
import math
import threading
import types
from typing import Callable, Dict, List, Mapping, Optional, Tuple

from ..harness.targets.base import Control, Target, TargetError
from .hat_model import DeviceSpec, HatModel

__all__ = ["VirtualTimeTarget", "VirtualTimeControl"]

_BOOTED: Dict[Tuple, HatModel] = {}


class VirtualTimeControl(Control):
    capabilities = frozenset({"plug", "unplug", "data", "motorfault", "portfault", "button", "adc", "rate",
                              "hold", "pos", "reset", "bootloader", "layout", "virtual_time", "faultpulse"})

    def __init__(self, target: VirtualTimeTarget):
        self._target = target

    def action(self, line: str) -> str:
        emu = self._target.emulator
        if emu is None:
            raise TargetError("the in-process target is not open")
        try:
            return emu.world(line)
        except Exception as exc:  # WorldError and bad lines: the message says what was wrong
            raise TargetError(f"{line.strip()}: {exc}") from None

    @property
    def time_scale(self) -> float:
        return self._target.scale

    def reset(self, bootloader: bool = False) -> None:
        self.action("@reset bootloader" if bootloader else "@reset")


class VirtualTimeTarget(Target):
    def __init__(self, firmware: Optional[str] = None, devices: Optional[Mapping[int, DeviceSpec]] = None,
                 seed: int = 0, baud: Optional[int] = None, scale: float = 1.0, boot: bool = True,
                 factory: Optional[Callable[..., HatModel]] = None, url: str = "inprocess",
                 version_string: Optional[str] = None, hang_after: Optional[int] = None,
                 fast_setup: bool = False):
        if scale <= 0:
            raise TargetError(f"inprocess: scale must be positive, got {scale}")
        self.url = url
        self.firmware, self.devices, self.seed, self.baud = firmware, dict(devices or {}), seed, baud
        self.scale = float(scale)
        self.boot = boot
        self.factory = factory
        self.version_string = version_string
        self.fast_setup = fast_setup    # devices set up faster than a HAT's 2400 baud (only when asked)
        if hang_after is not None and hang_after < 1:
            raise TargetError(f"inprocess: hang_after must be at least 1 line, got {hang_after}")
        self.hang_after = hang_after    # fault injection (emulator/hang.py), armed when opened
        self.emulator: Optional[HatModel] = None
        self.control = VirtualTimeControl(self)
        self.capabilities = frozenset({"control", "virtual_time", "drive_events", "device_frames",
                                       "line_records"})
        self.drive_events: List[dict] = []
        self.device_frames: List[dict] = []     # transcript ``dev`` events: what each device received
        self.line_records: List[object] = []
        # A session's reader thread may read while the test thread writes: one at a time.
        self._lock = threading.RLock()

    # -- Target ------------------------------------------------------------------------------
    def open(self) -> None:
        if self.emulator is not None:
            return
        self.emulator = self._booted_copy()
        if self.hang_after is not None:
            arm = getattr(self.emulator, "arm_hang", None)
            if arm is None:
                raise TargetError("inprocess: hang_after needs the emulator's own model, not a factory's")
            arm(self.hang_after)
        self.drive_events = []
        self.device_frames = []
        self.line_records = []
        self.emulator.on_event(self._on_event)
        hat = getattr(self.emulator, "hat", None)
        if hat is not None:
            hat.line_observers.append(self.line_records.append)

    def _new(self) -> HatModel:
        if self.factory is not None:
            return self.factory(firmware=self.firmware, devices=self.devices, seed=self.seed, baud=self.baud)
        return self.make_model()

    def make_model(self) -> HatModel:
        """A new HAT model when no ``factory`` was given (emulator/targets/in_process.py: the
        emulator)."""
        raise TargetError(f"{self.url}: no HAT model to serve (give a factory)")

    def _booted_copy(self) -> HatModel:
        if not self.boot:
            return self._new()
        # The class too: a target kind that makes its own model must not get another kind's copy.
        key = (type(self), self.factory, self.firmware, tuple(sorted(self.devices.items())), self.seed,
               self.baud, self.version_string, self.fast_setup)
        booted = _BOOTED.get(key)
        if booted is None:
            booted = self._new()
            try:
                booted.boot()
            except RuntimeError as exc:
                raise TargetError(f"inprocess: {exc}") from None
            booted.read()       # printed while nobody listened, as on sil: (scenario time 0 is the same)
            _BOOTED[key] = booted
        return _independent_copy(booted)

    def write(self, data: bytes) -> None:
        with self._lock:
            self._need_open().write(bytes(data))

    def read(self, timeout: float) -> bytes:
        with self._lock:
            emu = self._need_open()
            out = emu.read()
            if out:
                return out
            budget = max(0, math.ceil(timeout * 1000.0 * self.scale))
            until_output = getattr(emu, "advance_until_output", None)
            if until_output is not None:
                until_output(budget)
                return emu.read()
            while not out and budget > 0:   # a factory's emulator without it: one ms at a time
                emu.step()
                budget -= 1
                out = emu.read()
            return out

    def close(self) -> None:
        self.emulator = None

    # -- extras ------------------------------------------------------------------------------
    def advance(self, ms: int) -> None:
        """Let ``ms`` HAT milliseconds pass (output accumulates for the next read)."""
        with self._lock:
            self._need_open().advance(int(ms))

    def settle(self, min_ms: int, max_ms: int) -> int:
        """Let HAT time pass until the command port is at rest, between ``min_ms`` and
        ``max_ms``; returns the ms that passed. A HAT model that cannot tell (the emulator
        prints at once: there is no ring to drain) waits ``max_ms``."""
        with self._lock:
            emu = self._need_open()
            settle = getattr(emu, "settle", None)
            if settle is not None:
                return int(settle(int(min_ms), int(max_ms)))
            emu.advance(int(max_ms))
            return int(max_ms)

    @property
    def now(self) -> int:
        return int(self._need_open().now)

    def _on_event(self, event: dict) -> None:
        if event.get("dir") in ("pwm", "led"):
            self.drive_events.append(event)
        elif event.get("dir") == "dev":
            self.device_frames.append(event)

    def _need_open(self) -> HatModel:
        if self.emulator is None:
            raise TargetError("the in-process target is not open (call open() first)")
        return self.emulator


def _independent_copy(obj):  # type: ignore[no-untyped-def]
    """``copy.deepcopy``, plus closures re-pointed at the copies of what they captured.

    deepcopy shares function objects, so a lambda stored in the copy (``lambda: self.echo``)
    would still read the *original* object. Every closure found in an attribute, list or dict of
    a copied object is rebuilt with its cells mapped through the deepcopy memo.
    """
    memo: dict = {}
    dup = copy.deepcopy(obj, memo)
    copies = {id(v): v for v in memo.values()}

    def rebind(fn):  # type: ignore[no-untyped-def]
        if not isinstance(fn, types.FunctionType) or not fn.__closure__:
            return fn
        cells = []
        changed = False
        for cell in fn.__closure__:
            try:
                value = cell.cell_contents
            except ValueError:          # an empty cell
                cells.append(cell)
                continue
            new = memo.get(id(value), value)
            changed = changed or new is not value
            cells.append(types.CellType(new))
        if not changed:
            return fn
        out = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, tuple(cells))
        out.__kwdefaults__ = fn.__kwdefaults__
        return out

    for value in list(copies.values()):
        if isinstance(value, list):
            value[:] = [rebind(v) for v in value]
        elif isinstance(value, dict):
            for k, v in list(value.items()):
                value[k] = rebind(v)
        elif hasattr(value, "__dict__") and not isinstance(value, type):
            for k, v in list(vars(value).items()):
                if isinstance(v, types.FunctionType):
                    setattr(value, k, rebind(v))
    return dup

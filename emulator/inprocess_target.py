"""The reference emulator in this process, in virtual time: ``inprocess`` / ``inprocess:<release>``.

URL options (query string, as the ``emulator`` URL): ``device=P=SPEC`` (repeatable; SPEC as the
script ``@device``), ``seed=N``, ``baud=B`` (pace output at the wire rate), ``scale=S`` (see below),
``boot=0`` (do not run the start-up at open), ``version=TEXT`` (what ``version`` prints after
``Firmware version: ``, URL-encoded: a build the profiles do not know, e.g. ``1635608703``).

Time: nothing here reads the wall clock. Virtual time moves only inside :meth:`read` and
:meth:`advance`. ``read(timeout)`` steps the HAT one millisecond at a time, up to
``timeout * 1000 * time_scale`` HAT milliseconds, and returns as soon as output appears. So a
wall-clock sleep (``Session.wait_ms``) does not move the HAT; call :meth:`advance` (or read with
a timeout) to let HAT time pass. ``time_scale`` defaults to 1: a read timeout is HAT seconds.

Start-up: :meth:`open` boots the HAT until the layout's devices are established. A booted HAT is
kept per (release, layout, seed) and copied for every later open, so opening is cheap (the
fuzzer opens one per example).

Extras for white-box tools (the fuzzer): :attr:`emulator` (the Python API object),
:meth:`advance`, :attr:`drive_events` (transcript ``pwm``/``led`` events), :attr:`device_frames`
(transcript ``dev`` events: the frames each device received), :attr:`line_records`
(what each processed line ran, from ``hat.line_observers``).
"""
from __future__ import annotations

import copy
import math
import threading
import types
from typing import Any, Callable, Dict, List, Mapping, Optional, Protocol, Tuple, Union
from urllib.parse import parse_qs

from ..harness.targets.base import Control, Target, TargetError

__all__ = ["InProcessTarget", "InProcessControl", "HatModel", "from_url"]

DeviceSpec = Union[None, str, tuple]      # as the script's ``@device`` (protocol/devices.py)


class HatModel(Protocol):
    """What this target uses of its emulator: ``Emulator`` (emulator/api.py), or what a
    ``factory`` returns instead (e.g. a planted fault wrapping it, tests/planted/)."""

    @property
    def now(self) -> int: ...

    def boot(self) -> int: ...

    def write(self, data: bytes) -> None: ...

    def read(self) -> bytes: ...

    def step(self) -> None: ...

    def advance(self, ms: int) -> None: ...

    def world(self, line: str) -> str: ...

    def on_event(self, callback: Callable[[Dict[str, Any]], None]) -> None: ...


_BOOTED: Dict[Tuple, HatModel] = {}


class InProcessControl(Control):
    capabilities = frozenset({"plug", "unplug", "data", "motorfault", "portfault", "button", "adc", "rate",
                              "hold", "pos", "reset", "bootloader", "layout", "virtual_time", "faultpulse"})

    def __init__(self, target: InProcessTarget):
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


class InProcessTarget(Target):
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
        self.control = InProcessControl(self)
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
        from . import Emulator
        try:
            return Emulator(firmware=self.firmware, devices=self.devices, seed=self.seed, baud=self.baud,
                            version_string=self.version_string, fast_setup=self.fast_setup)
        except KeyError as exc:
            raise TargetError(f"inprocess: {exc.args[0]}") from None

    def _booted_copy(self) -> HatModel:
        if not self.boot:
            return self._new()
        key = (self.factory, self.firmware, tuple(sorted(self.devices.items())), self.seed, self.baud,
               self.version_string, self.fast_setup)
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


def _parse_devices(values: List[str]) -> Dict[int, DeviceSpec]:
    from ..protocol.devices import parse_device_spec
    out: Dict[int, DeviceSpec] = {}
    for v in values:
        port, sep, spec = v.partition("=")
        if not sep or not port.strip().isdigit():
            raise TargetError(f"inprocess: device option must be P=SPEC (e.g. 1=0x30), got {v!r}")
        try:
            out[int(port)] = parse_device_spec(spec)
        except (ValueError, KeyError) as exc:
            raise TargetError(f"inprocess: device {v!r}: {exc.args[0]}") from None
    return out


def from_url(url: str, **options) -> InProcessTarget:
    """``inprocess[:<release|latest>][?device=P=SPEC&seed=N&baud=B&scale=S&boot=0&version=TEXT&hang_after=N&fast_setup=1]``."""
    rest = url[len("inprocess"):] if url.startswith("inprocess") else url
    if rest and not rest.startswith((":", "?")):
        raise TargetError(f"not an inprocess URL: {url!r} (form: inprocess[:<release>][?options])")
    rest = rest[1:] if rest.startswith(":") else rest
    release, _, query = rest.partition("?")
    q = parse_qs(query, keep_blank_values=True)
    unknown = set(q) - {"device", "seed", "baud", "scale", "boot", "version", "hang_after", "fast_setup"}
    if unknown:
        raise TargetError(f"inprocess: unknown option(s) {sorted(unknown)} "
                          "(known: device, seed, baud, scale, boot, version, hang_after, fast_setup)")
    try:
        kwargs: Dict[str, Any] = dict(
            firmware=release or None,
            devices=_parse_devices(q.get("device", [])),
            seed=int(q["seed"][-1]) if "seed" in q else 0,
            baud=int(q["baud"][-1]) if "baud" in q else None,
            scale=float(q["scale"][-1]) if "scale" in q else 1.0,
            boot=q["boot"][-1] not in ("0", "false", "no") if "boot" in q else True,
            version_string=q["version"][-1] if "version" in q else None,
            hang_after=int(q["hang_after"][-1]) if "hang_after" in q else None,
            fast_setup=q["fast_setup"][-1] not in ("0", "false", "no") if "fast_setup" in q else False,
        )
    except ValueError as exc:
        raise TargetError(f"inprocess: bad option value in {url!r}: {exc}") from None
    kwargs.update(options)
    return InProcessTarget(url=url, **kwargs)

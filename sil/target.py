"""The real firmware in the loop: ``sil:TREE`` or ``sil:PROGRAM``, in virtual time.

``TREE`` is a Build HAT firmware tree (a ``firmware-pico/`` folder, or a checkout that has
one); it is built for the host with the project's stand-in on first use (cached; the same as
``buildhat-conformance sil build``). ``PROGRAM`` is a program that build made. The devices on
its ports are the emulator's device models, so world actions work as on ``inprocess``.

URL options: ``device=P=SPEC`` (repeatable), ``seed=N``, ``booted=0`` (open before the
start-up; default: open a HAT whose start-up is done), ``sanitize=address,undefined``,
``coverage=1``, ``suppressions=FILE`` (sanitizer reports the developer has acknowledged, in the
sanitizers' own ``kind:pattern`` format: listed as suppressed, not failed;
sil/sanitizer_reports.py), ``firmware=RELEASE`` (the release whose device-side timing the world uses;
default: latest). Time is virtual, as on ``inprocess`` (nothing reads the wall clock);
``speed=N`` runs it paced to the wall clock instead, N times real time, on a pseudo-terminal
(``buildhat-emulator --sil``), for host libraries and timing checks.
"""
from __future__ import annotations

import atexit
import os
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Tuple
from urllib.parse import parse_qs, unquote

from ..harness.targets.base import TargetCrashed, TargetError, keeps_process_resources
from ..serving.device_options import url_devices
from ..serving.hat_model import HatModel
from ..serving.virtual_time_target import VirtualTimeControl, VirtualTimeTarget
from .process import FirmwareDied
from .sanitizer_reports import FirmwareReport, Suppressions, SuppressionsError

if TYPE_CHECKING:
    from .hat import SilHat

__all__ = ["SilTarget", "SilControl", "from_url", "program_for", "close_templates"]


# Booted firmwares kept to be copied, by the process that started them: a forked process (a
# `fuzz --jobs` worker) must not talk to its parent's over the parent's pipes.
_BOOTED_FIRMWARES: Dict[tuple, Any] = {}


@atexit.register
@keeps_process_resources
def close_templates() -> None:
    """Quit the booted firmwares this process started (a forked child's are its parent's)."""
    for key in [k for k in _BOOTED_FIRMWARES if k[0] == os.getpid()]:
        _BOOTED_FIRMWARES.pop(key).close()


class SilControl(VirtualTimeControl):
    # No bootloader: a firmware tree's bootloader is not built.
    capabilities = frozenset({"plug", "unplug", "data", "motorfault", "portfault", "button", "adc", "rate",
                              "hold", "pos", "reset", "layout", "virtual_time", "faultpulse"})


# Builds found this process, by tree, options and the tree's file stamps: a campaign opens a
# target per run, and hashing the tree's sources each time cost ~20 ms a run.
_FOUND: Dict[tuple, Any] = {}


def _stamps(path: str) -> tuple:
    try:
        with os.scandir(path) as entries:
            return tuple(sorted((e.name, e.stat().st_mtime_ns, e.stat().st_size)
                                for e in entries if e.is_file()))
    except OSError:
        return ()


def program_for(where: str, sanitize: List[str], coverage: bool) -> Tuple[str, Any]:
    """The host program for a tree (built, or taken from the cache) or a given program; and the
    build (None for a given program)."""
    from .build import BuildError, build_tree
    path = os.path.expanduser(where)
    if os.path.isfile(path):
        if not os.access(path, os.X_OK):
            raise TargetError(f"sil:{where}: not an executable program "
                              "(give a firmware tree or a built program)")
        return os.path.abspath(path), None
    # (a tree edited since, or a checkout holding it in firmware-pico/, is looked up again)
    key = (os.path.abspath(path), tuple(sanitize), coverage, _stamps(path),
           _stamps(os.path.join(path, "firmware-pico")))
    build = _FOUND.get(key)
    if build is None or not build.program.exists():
        try:
            build = build_tree(path, sanitize=sanitize, coverage=coverage)
        except BuildError as exc:
            raise TargetError(f"sil: {exc}") from None
        if len(_FOUND) >= 16:
            _FOUND.clear()
        _FOUND[key] = build
    return str(build.program), build


class SilTarget(VirtualTimeTarget):
    """The firmware in a child process, the world in this one; one new HAT per open."""

    def __init__(self, program: str, url: str, devices: Optional[Dict[int, Any]] = None, seed: int = 0,
                 boot: bool = True, firmware: Optional[str] = None, build: Any = None,
                 suppressions: Optional[Suppressions] = None):
        super().__init__(firmware=firmware, devices=devices, seed=seed, boot=boot, url=url,
                         factory=self._make)
        self.program = program
        self.suppressions = suppressions or Suppressions(program=program)
        self.build = build          # the sil.build.Build when the URL named a tree
        self.disposable = True      # every open starts a new firmware process
        self.control = SilControl(self)
        # wire_input: host bytes cross a 115200-baud wire in HAT time (one per 87 us), so the HAT
        # may print between two bytes of one line (fuzz/running/target_exchange.py's ``timed``).
        # firmware_reports: a crash or a sanitizer report can only be the firmware's doing (there
        # is no power to fail): a finding, and the HAT is started again (take_firmware_reports).
        self.capabilities = frozenset({"control", "virtual_time", "drive_events", "device_frames",
                                       "wire_input", "firmware_reports"})

    # The firmware does not say what each line ran (the emulator's white-box ``line_records``):
    # tools that look for them treat this target as the black box it is.
    @property
    def line_records(self) -> Any:
        raise AttributeError("line_records")

    @line_records.setter
    def line_records(self, _value: Any) -> None:
        pass

    def _make(self, firmware: Optional[str] = None, devices: Optional[Dict[int, Any]] = None, seed: int = 0,
              baud: Optional[int] = None) -> HatModel:
        return self.new_hat(firmware, devices, seed)  # type: ignore[return-value]

    def new_hat(self, firmware: Optional[str] = None, devices: Optional[Dict[int, Any]] = None, seed: int = 0,
                record_events: bool = True) -> SilHat:
        """A new firmware process of this target's program, not yet booted: what every open starts
        from, and what ``sil serve`` runs at wall-clock pace (with ``record_events=False``, so a
        long serve keeps no event list)."""
        from pathlib import Path

        from ..protocol.profiles import get_profile
        from .build import program_version
        from .hat import SilHat
        built = program_version(Path(self.program))       # the release the tree's version.h names
        try:
            profile = get_profile(firmware if firmware not in (None, "") else built)
        except KeyError:
            if firmware:
                raise TargetError(f"sil: unknown release {firmware!r}") from None
            profile = get_profile(None)       # a build the profiles do not know: latest timing
        # The bootloader leaves the image's signature in RAM; a known release's is a fact.
        signature = None
        if built:
            try:
                known = get_profile(built)
                signature = known.signature if str(known.number) == built else None
            except KeyError:
                pass
        return SilHat(self.program, devices=devices, seed=seed, features=profile.features,
                      signature=signature, record_events=record_events)

    def _booted_copy(self) -> HatModel:
        if not self.boot:
            return self._new()
        # One booted firmware per program, layout and seed, kept for this process; every open
        # is a copy of it (the process forks), so a fuzzing run starts in a millisecond.
        key = (os.getpid(), self.program, tuple(sorted(self.devices.items())), self.seed, self.firmware)
        template: Any = _BOOTED_FIRMWARES.get(key)
        if template is None or template.died is not None:
            template = self._new()
            try:
                template.boot()
            except RuntimeError as exc:
                template.close()
                raise TargetError(f"sil: {exc}") from None
            template.read()                   # printed while nobody listened
            _BOOTED_FIRMWARES[key] = template
        try:
            return template.copy()
        except FirmwareDied as exc:
            raise TargetError(f"sil: {exc.summary}") from None

    def take_firmware_reports(self) -> List[FirmwareReport]:
        """The firmware's sanitizer reports (and the crash it died of) since the last call, each
        marked when the run's suppressions cover it."""
        hat: Any = self.emulator
        if hat is None:
            return []
        found = hat.take_reports()
        for report in found:
            report.suppressed_by = self.suppressions.match(report)
        return found

    @property
    def firmware_crashed(self) -> bool:
        """The firmware died (a signal, a report it could not go on after) and is not started again."""
        hat: Any = self.emulator
        return hat is not None and hat.died is not None and hat.died.kind == "crashed"

    def close(self) -> None:
        hat = self.emulator
        if hat is not None:
            close = getattr(hat, "close", None)
            if close is not None:
                close()
        super().close()

    def firmware_coverage(self) -> Optional[Any]:
        """The firmware's coverage so far (a ``coverage=1`` build, after close), else None."""
        if self.build is None or not self.build.coverage:
            return None
        from .firmware_coverage import coverage_summary
        try:
            return coverage_summary(self.build)
        except RuntimeError as exc:
            raise TargetError(f"sil: coverage: {exc}") from None

    def read(self, timeout: float) -> bytes:
        try:
            return super().read(timeout)
        except FirmwareDied as exc:
            if exc.kind == "crashed":
                raise TargetCrashed(exc.summary, exc.report) from None
            raise TargetError(exc.summary) from None


_KNOWN = {"device", "seed", "booted", "boot", "sanitize", "coverage", "firmware", "speed", "suppressions"}


def from_url(url: str, **options) -> Any:
    rest = url[len("sil:"):] if url.startswith("sil:") else ""
    where, _, query = rest.partition("?")
    where = unquote(where)
    if not where:
        raise TargetError("sil: needs a firmware tree or a built program: sil:PATH[?options]")
    q = parse_qs(query, keep_blank_values=True)
    unknown = set(q) - _KNOWN
    if unknown:
        raise TargetError(f"sil: unknown option(s) {sorted(unknown)} (known: {', '.join(sorted(_KNOWN))})")
    sanitize = [s for v in q.get("sanitize", []) for s in v.split(",") if s]
    coverage = q.get("coverage", ["0"])[-1] not in ("0", "false", "no", "")
    booted = q.get("booted", q.get("boot", ["1"]))[-1] not in ("0", "false", "no")
    devices = options.pop("devices", None) or url_devices(q.get("device", []), "sil")
    try:
        seed = int(q["seed"][-1]) if "seed" in q else 0
    except ValueError:
        raise TargetError(f"sil: seed must be a whole number, got {q['seed'][-1]!r}") from None
    firmware = q["firmware"][-1] if "firmware" in q else None
    program, build = program_for(where, sanitize, coverage)
    suppressions = None
    if "suppressions" in q:
        if "speed" in q:
            raise TargetError("sil: suppressions= is for the firmware in virtual time, not with speed=")
        try:
            suppressions = Suppressions.read(unquote(q["suppressions"][-1]), program)
        except SuppressionsError as exc:
            raise TargetError(f"sil: {exc}") from None
    if build is not None and build.coverage:
        from .firmware_coverage import reset_counts
        reset_counts(build)          # the figure at the end is this run's, not the sum of all runs
    if "speed" in q:
        # Paced to the wall clock: the firmware in its own real-time runner on a pty (sil/serve.py),
        # reached like the emulator target (same process handling and control channel).
        import sys

        from ..emulator.targets.pty_process import EmulatorTarget
        try:
            speed = float(q["speed"][-1])
        except ValueError:
            raise TargetError(f"sil: speed must be a number, got {q['speed'][-1]!r}") from None
        if speed <= 0:
            raise TargetError("sil: speed must be positive")
        command = [sys.executable, "-m", "buildhat_conformance.sil.serve", program]
        layout: Any = devices or None
        return EmulatorTarget(url, firmware=firmware or "latest", speed=speed, devices=layout,
                              booted=booted, seed=seed, command=command, **options)
    return SilTarget(program, url, devices=devices, seed=seed, boot=booted, firmware=firmware, build=build,
                     suppressions=suppressions, **options)


"""A release's shipped ``firmware.bin`` on an emulated RP2040: ``rp2040:IMAGE``, ``rp2040:R1`` ...
``rp2040:R7``, ``rp2040:<version>``, ``rp2040:latest``, in virtual time.

The image comes from an installed ``buildhat`` package or ``?images=DIR`` (``images.py``); the boot
ROM from ``?bootrom=FILE``, ``$BUILDHAT_RP2040_BOOTROM`` or the default place (``install.py``); Node.js
and rp2040js from ``buildhat-conformance rp2040 setup``. Each missing piece is one line.

URL options: ``images=DIR``, ``bootrom=FILE``, ``device=P=SPEC`` (repeatable; passive devices only
for now), ``seed=N``, ``booted=0`` (open before the start-up; default: a HAT whose start-up is done),
``firmware=RELEASE`` (the release whose device-side timing the world uses; default: the image's).
"""
from __future__ import annotations

from typing import Any, Dict, Optional
from urllib.parse import parse_qs, unquote

from ..harness.targets.base import NeedsCapability, TargetError
from ..serving.device_options import url_devices
from ..serving.hat_model import HatModel
from ..sil.target import SilControl, SilTarget
from .chip import Rp2040Hat, unwired_plug, unwired_ports
from .images import Image, find_image
from .install import check_rp2040js, find_bootrom, node_program

__all__ = ["Rp2040Target", "from_url"]


class Rp2040Control(SilControl):
    def action(self, line: str) -> str:
        if unwired_plug(line):
            raise NeedsCapability("an active device", "rp2040:", "the ports' UARTs are not yet wired to the "
                                  "chip's pins; passive devices and empty ports only")
        return super().action(line)


class Rp2040Target(SilTarget):
    """The chip in a Node.js child process, the world in this one; one new chip per open."""

    def __init__(self, image: Image, bootrom: Any, url: str, devices: Optional[Dict[int, Any]] = None,
                 seed: int = 0, boot: bool = True, firmware: Optional[str] = None):
        super().__init__(str(image.path), url, devices=devices, seed=seed, boot=boot, firmware=firmware)
        self.image, self.bootrom = image, bootrom
        self.control = Rp2040Control(self)
        self.reset_hint = "the rp2040: target resets through its control channel (@reset)"

    def new_hat(self, firmware: Optional[str] = None, devices: Optional[Dict[int, Any]] = None, seed: int = 0,
                record_events: bool = True) -> Rp2040Hat:
        from ..protocol.profiles import get_profile
        release = firmware if firmware not in (None, "") else self.image.release
        try:
            profile = get_profile(release)
        except KeyError:
            if firmware:
                raise TargetError(f"rp2040: unknown release {firmware!r}") from None
            profile = get_profile(None)        # an image the profiles do not know: latest timing
        # The bootloader leaves the image's signature in RAM; a known release's is a fact.
        signature, version = None, "unknown"
        if self.image.release is not None:
            try:
                known = get_profile(self.image.release)
                if known.number == self.image.release:
                    signature, version = known.signature, known.version_string
            except KeyError:
                pass
        return Rp2040Hat(self.image.path, self.bootrom, devices=devices, seed=seed, features=profile.features,
                         signature=signature, record_events=record_events, version=version)

    def _booted_copy(self) -> HatModel:
        hat = self._new()
        if self.boot:
            try:
                hat.boot()   # type: ignore[attr-defined]
            except RuntimeError as exc:
                close = getattr(hat, "close", None)
                if close is not None:
                    close()
                raise TargetError(f"rp2040: {exc}") from None
        return hat


_KNOWN = {"images", "bootrom", "device", "seed", "booted", "boot", "firmware", "speed"}


def from_url(url: str, **options) -> Any:
    rest = url[len("rp2040:"):] if url.startswith("rp2040:") else ""
    where, _, query = rest.partition("?")
    where = unquote(where)
    q = parse_qs(query, keep_blank_values=True)
    unknown = set(q) - _KNOWN
    if unknown:
        raise TargetError(f"rp2040: unknown option(s) {sorted(unknown)} (known: {', '.join(sorted(_KNOWN))})")
    if "speed" in q:
        raise TargetError("rp2040: ?speed (wall-clock pace on a pty) is not available yet; the target runs "
                          "in virtual time")
    booted = q.get("booted", q.get("boot", ["1"]))[-1] not in ("0", "false", "no")
    devices = options.pop("devices", None) or url_devices(q.get("device", []), "rp2040")
    unwired = unwired_ports(devices)
    if unwired:
        raise TargetError(f"rp2040: port {min(unwired)}: active devices are not yet wired to the chip's pins "
                          "(passive devices and empty ports only)")
    try:
        seed = int(q["seed"][-1]) if "seed" in q else 0
    except ValueError:
        raise TargetError(f"rp2040: seed must be a whole number, got {q['seed'][-1]!r}") from None
    firmware = q["firmware"][-1] if "firmware" in q else None
    node_program()
    check_rp2040js()
    bootrom = find_bootrom(q["bootrom"][-1] if "bootrom" in q else None)
    image = find_image(where, q["images"][-1] if "images" in q else None)
    return Rp2040Target(image, bootrom, url, devices=devices, seed=seed, boot=booted, firmware=firmware,
                        **options)

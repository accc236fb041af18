"""The reference emulator in this process, in virtual time: ``inprocess`` / ``inprocess:<release>``.

URL options (query string, as the ``emulator`` URL): ``device=P=SPEC`` (repeatable; SPEC as the
script ``@device``), ``seed=N``, ``baud=B`` (pace output at the wire rate), ``scale=S`` (a read
timeout is ``S`` times as many HAT seconds), ``boot=0`` (do not run the start-up at open),
``version=TEXT`` (what ``version`` prints after ``Firmware version: ``, URL-encoded: a build the
profiles do not know, e.g. ``1635608703``), ``hang_after=N``, ``fast_setup=1``. How virtual time
moves: serving/virtual_time_target.py.
"""
from __future__ import annotations

from typing import Any, Dict
from urllib.parse import parse_qs

from ...harness.targets.base import TargetError
from ...serving.device_options import url_devices
from ...serving.hat_model import HatModel
from ...serving.virtual_time_target import VirtualTimeTarget

__all__ = ["InProcessTarget", "from_url"]


class InProcessTarget(VirtualTimeTarget):
    """The emulator (emulator/api.py) as a virtual-time target, or what a ``factory`` returns."""

    def make_model(self) -> HatModel:
        from ..api import Emulator
        try:
            return Emulator(firmware=self.firmware, devices=self.devices, seed=self.seed, baud=self.baud,
                            version_string=self.version_string, fast_setup=self.fast_setup)
        except KeyError as exc:
            raise TargetError(f"inprocess: {exc.args[0]}") from None


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
            devices=url_devices(q.get("device", []), "inprocess"),
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

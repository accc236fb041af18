"""Devices on the ports, as every served HAT takes them: ``P=SPEC`` (SPEC as the scenario script's
``@device``, protocol/devices.py), from a target URL's ``device=`` options or a ``--device`` option."""
from __future__ import annotations

import argparse
from typing import Dict, List, Optional

from ..harness.targets.base import TargetError
from ..protocol.devices import parse_device_spec
from .hat_model import DeviceSpec

__all__ = ["url_devices", "device_options"]


def url_devices(values: List[str], scheme: str) -> Dict[int, DeviceSpec]:
    """A target URL's ``device=P=SPEC`` options as a layout; a bad one is a :class:`TargetError`
    naming the URL's ``scheme``."""
    out: Dict[int, DeviceSpec] = {}
    for v in values:
        port, sep, spec = v.partition("=")
        if not sep or not port.strip().isdigit():
            raise TargetError(f"{scheme}: device option must be P=SPEC (e.g. 1=0x30), got {v!r}")
        try:
            out[int(port)] = parse_device_spec(spec)
        except (ValueError, KeyError) as exc:
            raise TargetError(f"{scheme}: device {v!r}: {exc.args[0]}") from None
    return out


def device_options(specs: List[str], parser: argparse.ArgumentParser) -> Dict[int, Optional[tuple]]:
    """``--device P=SPEC`` options as a layout; a bad one is the parser's one-line error."""
    out: Dict[int, Optional[tuple]] = {}
    for item in specs:
        port, sep, spec = item.partition("=")
        if not sep or port.strip() not in ("0", "1", "2", "3"):
            parser.error(f"--device {item!r}: expected P=SPEC with P in 0..3")
        try:
            out[int(port)] = parse_device_spec(spec)
        except (ValueError, KeyError) as exc:
            parser.error(f"--device {item!r}: {exc.args[0] if exc.args else exc}")
    return out

"""``@data`` control lines for a device reading, encoded from the device catalogue (devices.json).

A test says "the colour sensor on port 0 reads RGBI 1000 40 40 900"; this turns it into the bytes the
device would send for that mode (little-endian, the mode's dataset type), e.g. ``@data 0 5 E8 03 ...``.
"""
from __future__ import annotations

import struct
from typing import Sequence

from buildhat_conformance.protocol.devices import active_device

__all__ = ["data_line", "auto_line"]

_PACK = {"int8": "<b", "int16": "<h", "int32": "<i", "float": "<f"}


def data_line(port: int, type_id: int, mode: int, values: Sequence[float]) -> str:
    """``@data P M HH..`` for ``values`` in the format the catalogue gives that device's mode."""
    spec = active_device(type_id)["modes"][mode]
    fmt = spec["format"]
    if len(values) != fmt["count"]:
        raise ValueError(f"0x{type_id:02X} mode {mode} ({spec['name']}) has {fmt['count']} values, "
                         f"got {len(values)}")
    pack = _PACK[fmt["type_name"]]
    payload = b"".join(struct.pack(pack, v if pack == "<f" else int(v)) for v in values)
    return f"@data {port} {mode} " + " ".join(f"{b:02X}" for b in payload)


def auto_line(port: int, mode: int) -> str:
    """Back to the device model's own values."""
    return f"@data {port} {mode} auto"

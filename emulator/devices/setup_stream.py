"""The LUMP setup messages a device sends to the HAT, built from its devices.json entry.

Order (as LEGO devices send it): TYPE, MODES (the 4-byte extended form when the catalogue's
``modes_message_payload`` has 4 bytes), SPEED, VERSION, then per mode from the highest index down:
NAME, RAW, PCT, SI, SYMBOL, MAPPING, FORMAT; mode 0 also carries the COMBI masks and the
SPEED-PID / POS-PID words (only when the device has them); the stream ends with ACK.

VERSION carries two little-endian 32-bit words; the HAT prints the first as ``hwver`` and the
second as ``swver`` (protocol/devices.json's ``_meta`` ``field_guide``), so the words are taken from
those catalogue fields in that order.
"""
from __future__ import annotations

import struct
from typing import List

from ..ports import lpf2

__all__ = ["setup_messages", "name_payload", "modes_payload"]


def modes_payload(entry: dict) -> bytes:
    """MODES payload: the catalogue's bytes, else the short form [nmodes, nview]."""
    given = entry.get("modes_message_payload")
    if given:
        return bytes(given)
    return bytes([entry["nmodes"], entry["nview"]])


def name_payload(mode: dict) -> bytes:
    """Mode name, and for names of at most 5 characters the 6 flag bytes after a NUL."""
    name = mode["name"].encode("ascii")
    flags = mode.get("name_flags_hex")
    if flags and len(name) <= 5:
        return name + bytes(6 - len(name)) + bytes.fromhex(flags)
    return name


def _range(lo: float, hi: float) -> bytes:
    return struct.pack("<ff", float(lo), float(hi))


def _pid(words: List[int]) -> bytes:
    return struct.pack("<4i", *[int(w) for w in words])


def setup_messages(entry: dict) -> List[bytes]:
    """Every setup message (checksummed frames) of one active device, in sending order."""
    out = [
        lpf2.device_message(lpf2.CMD, lpf2.CMD_TYPE, bytes([entry["type_id"]])),
        lpf2.device_message(lpf2.CMD, lpf2.CMD_MODES, modes_payload(entry)),
        lpf2.device_message(lpf2.CMD, lpf2.CMD_SPEED, struct.pack("<I", entry["baud"])),
        lpf2.device_message(lpf2.CMD, lpf2.CMD_VERSION,
                            struct.pack("<II", int(entry["hwver"], 16), int(entry["swver"], 16))),
    ]
    for mode in sorted(entry["modes"], key=lambda m: -m["index"]):
        i = mode["index"]
        fmt = mode["format"]
        symbol = mode.get("symbol", "").encode("ascii")
        out += [
            lpf2.info_message(i, lpf2.INFO_NAME, name_payload(mode)),
            lpf2.info_message(i, lpf2.INFO_RAW, _range(mode["raw_min"], mode["raw_max"])),
            lpf2.info_message(i, lpf2.INFO_PCT, _range(mode["pct_min"], mode["pct_max"])),
            lpf2.info_message(i, lpf2.INFO_SI, _range(mode["si_min"], mode["si_max"])),
            lpf2.info_message(i, lpf2.INFO_SYMBOL, symbol or b"\x00"),
            lpf2.info_message(i, lpf2.INFO_MAPPING,
                              bytes([mode.get("mapping_in") or 0, mode.get("mapping_out") or 0])),
            lpf2.info_message(i, lpf2.INFO_FORMAT,
                              bytes([fmt["count"], fmt["type"], fmt["chars"], fmt["dp"]])),
        ]
        if i == 0:
            masks = entry.get("combi_masks") or []
            if masks:
                out.append(lpf2.info_message(0, lpf2.INFO_COMBI,
                                             b"".join(struct.pack("<H", m) for m in masks)))
            for info, key in ((lpf2.INFO_SPEED_PID, "speed_pid"), (lpf2.INFO_POS_PID, "position_pid")):
                words = entry.get(key) or [0, 0, 0, 0]
                if any(words):
                    out.append(lpf2.info_message(0, info, _pid(words)))
    out.append(bytes([lpf2.ACK]))
    return out

"""The LPF2 device catalogue (a verbatim copy of the developers' original) as Python objects."""
from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources
from typing import Optional

__all__ = ["catalogue", "active_device", "active_type_ids", "passive_ids", "passive_device",
           "parse_device_spec", "DEFAULT_LAYOUT"]

# Scenario-script default layout (docs/formats/SCENARIO-SCRIPT.md): P0 0x30, P1 0x40, P2 passive 8, P3 none.
DEFAULT_LAYOUT = {0: ("active", 0x30), 1: ("active", 0x40), 2: ("passive", 8), 3: None}


@lru_cache(maxsize=1)
def catalogue() -> dict:
    data = resources.files(__name__.rpartition(".")[0]).joinpath("devices.json")   # in this package
    text = data.read_text(encoding="utf-8")
    return json.loads(text)


def active_type_ids() -> list:
    return sorted(int(k, 16) for k in catalogue() if k.startswith("0x"))


def active_device(type_id: int) -> dict:
    key = f"0x{type_id:02X}"
    try:
        return catalogue()[key]
    except KeyError:
        known = ", ".join(f"0x{t:02X}" for t in active_type_ids())
        raise KeyError(f"no active device type {key} in the catalogue (known: {known})") from None


def passive_ids() -> list:
    return sorted(int(k) for k in catalogue()["passive"])


def passive_device(pid: int) -> dict:
    return catalogue()["passive"][str(pid)]


def format_device_spec(spec: Optional[tuple]) -> str:
    """The SPEC text (as in a script's ``@device``) of a parsed spec: the inverse of
    :func:`parse_device_spec`."""
    if spec is None:
        return "none"
    kind, ident = spec
    return f"0x{ident:02X}" if kind == "active" else f"passive {ident}"


def parse_device_spec(spec: str):
    """Parse a device SPEC as in the script format's ``@device``.

    ``0x30`` -> ("active", 0x30); ``passive 8`` -> ("passive", 8); ``none`` -> None.
    Raises ValueError with a readable message for anything else.
    """
    s = " ".join(spec.strip().split())
    if s.lower() == "none":
        return None
    if s.lower().startswith("passive"):
        rest = s[len("passive"):].strip()
        if not rest.isdigit() or int(rest) not in passive_ids():
            raise ValueError(f"passive device id must be one of {passive_ids()}, got {rest!r}")
        return ("passive", int(rest))
    if s.lower().startswith("0x"):
        try:
            tid = int(s, 16)
        except ValueError:
            raise ValueError(f"bad active type id {s!r}") from None
        active_device(tid)  # raises KeyError with the known list
        return ("active", tid)
    raise ValueError(f"device spec must be 0xHH, 'passive N' or 'none', got {spec!r}")

"""What the fuzzer needs to know of a target URL before it opens one: does every open start a new HAT,
does it run in HAT time, does its output pass a TX ring that a full wire fills (fuzz/model/tx_ring.py)."""
from __future__ import annotations

from typing import Callable, Dict, Optional, Tuple, Union
from urllib.parse import parse_qs, urlsplit

from ...harness.targets import make_target
from ...harness.targets.base import Target

__all__ = ["scheme", "is_fresh", "is_virtual", "is_wire", "has_tx_ring", "ring_sides", "sides_rings",
           "opener_for", "fresh_boot_options", "FRESH_SCHEMES", "VIRTUAL_SCHEMES", "OWN_SCHEMES"]

FRESH_SCHEMES = ("inprocess", "emulator", "cmd", "sil")   # every open starts a new, freshly booted HAT
VIRTUAL_SCHEMES = ("inprocess", "sil")     # HAT time, not wall time: the in-process emulator, the firmware
OWN_SCHEMES = ("inprocess", "emulator", "sil")   # HATs this program starts itself (--jobs auto runs several)


def scheme(url: str) -> str:
    """The URL's kind: ``sil``, ``inprocess``, ``/dev/ttyAMA0`` ..."""
    return url.split(":", 1)[0].split("?", 1)[0].lower()


def is_fresh(url: str) -> bool:
    return scheme(url) in FRESH_SCHEMES


def is_wire(url: str) -> bool:
    """A paced or real 115200-baud wire: a serial port or socket, or an emulator told ``baud=``
    (a pty, a pipe or the in-process emulator unpaced move bytes as fast as they come)."""
    kind = scheme(url)
    if kind in ("cmd", "loop"):
        return False
    if kind == "sil":              # HAT time, unless paced to the wall clock (speed=)
        return "speed=" in url
    if kind in ("inprocess", "emulator"):
        target = make_target(url)
        return bool(getattr(target, "baud", None) or getattr(target, "wire_baud", None))
    return True


def _one_ring(url: str) -> bool:
    return is_wire(url) or scheme(url) not in ("inprocess", "emulator")


def has_tx_ring(url: str, against: Optional[str] = None) -> bool:
    """Output may meet a full TX ring (fuzz/model/tx_ring.py): any target but our emulator unpaced, whose
    output never waits (a `cmd:` target may be firmware behind a pipe, with a ring of its own)."""
    return _one_ring(url) or bool(against and _one_ring(against))


def ring_sides(url: str, against: Optional[str] = None) -> Tuple[bool, ...]:
    """:func:`has_tx_ring` per side, target first: only a side with a ring pauses for it."""
    return (_one_ring(url),) + ((_one_ring(against),) if against else ())


def sides_rings(target: str, against: Optional[str], secondary: Optional[Callable[[], Target]]
                 ) -> Union[bool, Tuple[bool, ...]]:
    """The runner's ``tx_ring``: per side when both URLs are known (a second target given as an
    opener alone, with no URL, shares the first's)."""
    if secondary is not None and not against:
        return has_tx_ring(target)
    return ring_sides(target, against)


def opener_for(url: str) -> Callable[[], Target]:
    make_target(url)   # fail early with the registry's message for a bad URL
    options = fresh_boot_options(url)
    return lambda: make_target(url, **options)


def fresh_boot_options(url: str) -> Dict[str, bool]:
    """What makes a new target of ``url`` start as the fuzzer takes every fresh open to start:
    booted, its layout's devices established (``inprocess`` and ``sil:`` open so by default).
    The ``emulator`` process starts at power-on unless told ``booted``, and its devices take
    about 0.8 s of HAT time to connect: a differential run's first `list` (sil finding, seed 5)
    compared that with a booted side. A URL that says ``booted`` or ``bootloader`` is obeyed."""
    if scheme(url) != "emulator":
        return {}
    query = parse_qs(urlsplit("x:" + url[len("emulator"):].lstrip(":")).query, keep_blank_values=True)
    return {} if "booted" in query or "bootloader" in query else {"booted": True}


def is_virtual(url: str) -> bool:
    """HAT time, not wall time: the in-process emulator, the firmware in the loop."""
    return scheme(url) in VIRTUAL_SCHEMES

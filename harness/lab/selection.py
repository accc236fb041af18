"""``--places SPEC``: which places of the lab a run (or a fuzz campaign) uses, and holding them.

SPEC is a labgrid tag ``key=value`` (``board=buildhat``: the places tagged so) or a pattern
matched as ``labgrid-client -p`` matches one: a substring of the place's name or of an alias.
Free places are used; a place someone holds is skipped with one line, unless ``--lab-wait``
gives it that long to come free. The run holds every place it uses until it ends
(:class:`PlaceLease`), and hands them to its children (``BUILDHAT_LAB_HOLDER``).
"""
from __future__ import annotations

import argparse
import os
import time
from typing import Callable, List, Optional
from urllib.parse import quote

from ...plumbing.cli_options import UsageError
from ..targets.base import TargetError
from .client import LabClient, PlaceHeld, PlaceState, client_for
from .lease import HOLDER_ENV, PlaceLease

__all__ = ["matching", "LabHold", "hold_places", "place_url", "add_lab_arguments"]


def matching(states: List[PlaceState], spec: str) -> List[PlaceState]:
    """The places SPEC names (module docstring), in name order."""
    if "=" in spec:
        key, _, value = spec.partition("=")
        return [s for s in states if s.tags.get(key.strip()) == value.strip()]
    return [s for s in states if spec in s.name or any(spec in a for a in s.aliases)]


def place_url(name: str, coordinator: str) -> str:
    return f"labgrid:{quote(name)}?coordinator={coordinator}"


class LabHold:
    """The places a run holds: ``(place name, target URL)`` each; :meth:`release` gives them back."""

    def __init__(self, client: LabClient, leases: List[PlaceLease]):
        self.client, self.leases = client, leases
        self.places = [(lease.name, place_url(lease.name, client.address)) for lease in leases]
        if not any(lease.inherited for lease in leases):     # else our own run holds them already
            os.environ[HOLDER_ENV] = str(os.getpid())        # our children use what we hold

    def release(self) -> None:
        for lease in self.leases:
            lease.give_back()


def hold_places(spec: Optional[str], urls: List[str], wait: float, coordinator: str = "",
                say: Callable[[str], None] = print) -> Optional[LabHold]:
    """Hold the places of ``--places SPEC`` or of the ``labgrid:`` URLs among ``urls``; None when
    the run uses no labgrid place. Raises UsageError (nothing matches) or TargetError/PlaceHeld."""
    from ..targets.labgrid_place import from_url
    from . import need_labgrid

    try:        # a bad URL, or labgrid not installed: a usage error, as preflight makes it
        named = [from_url(u) for u in urls if u.split(":", 1)[0].lower() == "labgrid"]
        if not spec and not named:
            return None
        need_labgrid()
    except TargetError as exc:
        raise UsageError(" ".join(str(exc).split())) from None
    if spec and named:
        raise UsageError("--places and a labgrid: --target do not go together; give one of them")
    client = client_for(coordinator or (named[0].coordinator if named else ""))
    if spec:
        states = matching(client.places(), spec)
        if not states:
            known = ", ".join(s.name for s in client.places()) or "none"
            raise UsageError(f"--places {spec}: no place of the labgrid coordinator at {client.address} "
                             f"matches (places: {known}; a tag is key=value)")
        names = _usable(client, states, wait, spec, say)
    else:
        names = [t.place for t in named]
        wait = max([wait] + [t.wait for t in named])
    deadline = time.monotonic() + max(0.0, wait)
    leases: List[PlaceLease] = []
    try:
        for name in names:
            lease = PlaceLease(client, name, wait=max(0.0, deadline - time.monotonic()))
            if wait > 0 and client.place(name).acquired:
                say(f"waiting up to {wait:g} s for place {name} ({client.place(name).holder_text()})")
            try:
                lease.take()
            except PlaceHeld as exc:
                if not spec or wait > 0:
                    raise
                say(f"skipped: {exc}")        # another run of this machine took it just now
                continue
            leases.append(lease)
        if not leases:
            raise PlaceHeld(f"--places {spec}: every matching place is held; "
                            "--lab-wait SECONDS waits for one")
    except BaseException:
        for lease in leases:
            lease.give_back()
        raise
    return LabHold(client, leases)


def _usable(client: LabClient, states: List[PlaceState], wait: float, spec: str,
            say: Callable[[str], None]) -> List[str]:
    if wait > 0:
        return [s.name for s in states]
    usable = [s.name for s in states if not s.acquired or s.acquired == client.me]
    for s in states:
        if s.name not in usable:
            say(f"place {s.name} is {s.holder_text()}: skipped (--lab-wait SECONDS waits for it)")
    if not usable:
        raise PlaceHeld(f"--places {spec}: every matching place is held "
                        f"({', '.join(f'{s.name}: {s.acquired}' for s in states)}); "
                        "--lab-wait SECONDS waits for one")
    return usable


def add_lab_arguments(parser: argparse.ArgumentParser, what: str = "the suite, one worker per place") -> None:
    parser.add_argument("--places", default=None, metavar="PATTERN|KEY=VALUE",
                        help=f"{what}, on every free place of the labgrid lab whose name contains PATTERN "
                             "or that is tagged KEY=VALUE, all at once (docs/LAB.md)")
    parser.add_argument("--lab-wait", type=float, default=0.0, metavar="SECONDS",
                        help="wait this long for a held labgrid place to come free (default: do not wait: "
                             "a held place is skipped, or is one line and exit status 3)")
    parser.add_argument("--coordinator", default="", metavar="HOST:PORT",
                        help="the labgrid coordinator (default: LG_COORDINATOR, else 127.0.0.1:20408)")

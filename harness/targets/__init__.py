"""Targets: how bytes reach a HAT. One small module per kind, chosen by URL.

| URL | module |
|---|---|
| ``/dev/...`` or any existing path, ``serial:///dev/...?baud=115200`` | ``serial_device`` |
| ``socket://``, ``rfc2217://``, ``loop://`` and other pyserial URLs | ``pyserial_url`` |
| ``cmd:<command line>`` | ``cmd`` |
| ``labgrid:PLACE[?coordinator=HOST:PORT...]`` | ``labgrid_place`` (the ``lab`` extra) |
| ``emulator``, ``emulator:<release|latest>[?speed=N&device=P=SPEC...]`` | emulator/targets/pty_process.py |
| ``inprocess[:...]`` | emulator/targets/in_process.py |
| ``sil:<tree or program>[?...]`` | sil/target.py (the real firmware in the loop) |

Each module provides ``from_url(url, **options) -> Target``; it is imported only when its
URL is used. The last three start what lives above this folder (an emulator, the firmware), so
they are found through the package's entry points (group ``buildhat_conformance.targets``,
pyproject.toml), never imported from here. :func:`make_target` builds a target;
:func:`open_target` also opens it.
"""
from __future__ import annotations

import importlib
import os
from importlib import metadata
from typing import Any, Callable, Dict, List, Optional, Tuple

from .base import Control, NeedsCapability, Target, TargetError

__all__ = ["make_target", "open_target", "register", "url_forms", "Target", "Control", "TargetError",
           "NeedsCapability"]

_PKG = __name__

# scheme -> module (in this package) providing from_url; "" marks a path.
_SCHEMES: Dict[str, str] = {
    "cmd": "cmd",
    "serial": "serial_device",
    "socket": "pyserial_url",
    "rfc2217": "pyserial_url",
    "loop": "pyserial_url",
    "spy": "pyserial_url",
    "hwgrep": "pyserial_url",
    "alt": "pyserial_url",
    "cp2110": "pyserial_url",
    "labgrid": "labgrid_place",
}
_FACTORIES: Dict[str, Callable[..., Target]] = {}
# scheme -> entry point of a target module above harness/ (emulator/, sil/); read once.
_ENTRY_POINT_GROUP = "buildhat_conformance.targets"
_ENTRY_POINTS: Optional[Dict[str, Any]] = None

_FORMS: List[Tuple[str, str]] = [
    ("emulator[:<release|latest>][?speed=N&device=P=SPEC]", "the reference emulator on a pty"),
    ("inprocess[:<release>][?device=P=SPEC]", "the reference emulator in this process, virtual time"),
    ("sil:<firmware tree or built program>[?device=P=SPEC]",
     "the real firmware built for this host, virtual time"),
    ("/dev/ttyAMA0, /dev/serial0, /dev/ttyUSB0 ...", "a HAT on a local serial port"),
    ("serial:///dev/ttyAMA0?baud=115200", "the same, with options"),
    ("socket://HOST:PORT, rfc2217://HOST:PORT", "a HAT on another machine (ser2net)"),
    ("loop://", "pyserial's loopback (echoes what is sent)"),
    ("cmd:<command line>", "a program speaking the protocol on stdin/stdout"),
    ("labgrid:PLACE[?coordinator=HOST:PORT]", "a place of a labgrid lab, acquired for the run (docs/LAB.md)"),
]


def register(scheme: str, factory: Callable[..., Target]) -> None:
    """Add (or replace) the factory for a URL scheme: ``factory(url, **options) -> Target``."""
    _FACTORIES[scheme] = factory


def url_forms() -> List[Tuple[str, str]]:
    """(form, meaning) of every URL this registry understands, for help texts."""
    return list(_FORMS)


def _entry_points() -> Dict[str, Any]:
    """The target modules the installed package names for this folder (pyproject.toml)."""
    global _ENTRY_POINTS
    if _ENTRY_POINTS is None:
        found = metadata.entry_points()
        group = found.select(group=_ENTRY_POINT_GROUP) if hasattr(found, "select") \
            else found.get(_ENTRY_POINT_GROUP, [])    # Python 3.9: a dict of groups
        _ENTRY_POINTS = {ep.name: ep for ep in group}
    return _ENTRY_POINTS


def _scheme(url: str) -> str:
    """The URL's scheme, or "" for a device path. Known schemes win over same-named paths
    (a checkout has an ``emulator/`` folder; ``emulator`` still means the emulator)."""
    head = url.split(":", 1)[0].split("?", 1)[0].lower()
    if head in _SCHEMES or head in _FACTORIES or head in _entry_points():
        return head
    if url.startswith(("/", ".")) or os.path.exists(url):
        return ""
    return head


def make_target(url: str, **options) -> Target:
    """The target for a URL, not yet opened. Raises TargetError for URLs nobody handles."""
    url = url.strip()
    if not url:
        raise TargetError("no target given; " + _known())
    scheme = _scheme(url)
    if scheme == "":
        scheme = "serial"
    factory = _FACTORIES.get(scheme)
    if factory is None and scheme in _entry_points():
        try:
            factory = _entry_points()[scheme].load()
        except ModuleNotFoundError as exc:
            raise TargetError(f"target kind {scheme!r} is not available in this build ({exc.name})") from exc
    if factory is None:
        module_name = _SCHEMES.get(scheme)
        if module_name is None:
            close = [k for k in [*_SCHEMES, *_entry_points()] if scheme.startswith(k)]
            hint = f" (did you mean {close[0]}:{url[len(close[0]):]}?)" if close else ""
            raise TargetError(f"unknown target {url!r}{hint}; " + _known())
        try:
            module = importlib.import_module(f"{_PKG}.{module_name}")
        except ModuleNotFoundError as exc:
            if exc.name and exc.name.endswith(module_name):
                raise TargetError(f"target kind {scheme!r} is not available in this build") from exc
            raise
        factory = module.from_url
    return factory(url, **options)


def open_target(url: str, **options) -> Target:
    """:func:`make_target`, opened. Raises TargetError with an actionable message on failure."""
    target = make_target(url, **options)
    target.open()
    return target


def _known() -> str:
    return "known targets: " + "; ".join(f"{form} ({what})" for form, what in _FORMS)

"""Firmware release profiles (R1..R7) as data: command tables, help text, features.

The JSON beside this module is transcribed from the facts: FIRMWARE-BEHAVIOUR.md#fb-releases,
#fb-command-table, #fb-help, #fb-versions.
A new firmware release is a new entry in ``profiles.json``, not new code. A build the package does
not know is described by the user in a profiles file (``--profiles FILE``, or the environment variable
``BUILDHAT_CONFORMANCE_PROFILES``; docs/PROFILES.md, protocol/profile_file.py): this module is
the one loader, and merges its entries with the releases above.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from functools import cache, cached_property, lru_cache
from importlib import resources
from typing import Any, Optional

__all__ = ["Profile", "load_profiles", "use_profiles_file", "PROFILES_ENV", "get_profile", "resolve_version",
           "neighbours", "undecided_features",
           "profile_numbers", "bootloader_data", "passive_signature_ids", "DEFAULT_FIRMWARE"]


@lru_cache(maxsize=1)
def _raw() -> dict:
    data = resources.files(__name__.rpartition(".")[0]).joinpath("profiles.json")   # in this package
    text = data.read_text(encoding="utf-8")
    return json.loads(text)


DEFAULT_FIRMWARE: int = int(_raw()["default"])
#: the user's profiles file, for this process and the ones it starts (the suite's pytest, emulators)
PROFILES_ENV = "BUILDHAT_CONFORMANCE_PROFILES"


@dataclass(frozen=True)
class Profile:
    """One firmware release as the command port shows it."""

    name: str                 # "R1" .. "R7"
    number: int               # the number `version` prints first, e.g. 1737564117
    version_string: str       # text after "Firmware version: "
    commands: tuple           # command table in the firmware's matching order
    set_keywords: tuple       # `set` sub-keywords in matching order
    help_lines: tuple         # exact help text, one entry per CRLF-terminated line
    signature: Optional[bytes]  # the release's 64-byte signature, None if unknown
    image_size: int
    image_checksum: int
    features: dict = field(default_factory=dict)
    base: str = ""            # a build of a profiles file: the release it starts from; else ""

    def has(self, command: str) -> bool:
        return command in self.commands

    def feature(self, key: str) -> Any:
        return self.features[key]

    @property
    def document_language(self) -> bool:
        """True when the command language is the 2021-10 document's (R1-R4)."""
        return bool(self.features["document_language"])

    @cached_property
    def help_bytes(self) -> bytes:
        # Cached (the dataclass is frozen, so the text never changes): `help` is answered and
        # predicted thousands of times a second while fuzzing (H10 profile).
        return b"".join(line.encode("utf-8") + b"\r\n" for line in self.help_lines)

    def __str__(self) -> str:
        return f"{self.name} ({self.number})"


_CORE_KEYS = {"name", "number", "version_string", "commands", "set_keywords", "help_text",
              "signature", "image_size", "image_checksum", "help_lines", "base"}


@cache
def load_profiles() -> dict:
    """All known profiles, keyed by release number, in release order: the releases of
    profiles.json, and the builds of the user's profiles file (:func:`use_profiles_file`)."""
    raw = _raw()
    entries = dict(raw["profiles"])
    path = os.environ.get(PROFILES_ENV)
    if path:
        from .profile_file import read_profile_file
        entries.update(read_profile_file(path, raw))
    out = {}
    # Model values every profile gets unless it sets its own (cost model, device timing ...).
    defaults = {k: v for k, v in raw.get("model_defaults", {}).items() if not k.startswith("_")}
    for num, p in entries.items():
        sig = bytes.fromhex(p["signature"]) if p.get("signature") else None
        help_lines = p["help_lines"] if "help_lines" in p else raw["help_texts"][p["help_text"]]
        out[int(num)] = Profile(
            name=p["name"], number=int(num), version_string=p["version_string"],
            commands=tuple(p["commands"]), set_keywords=tuple(p["set_keywords"]),
            help_lines=tuple(help_lines), signature=sig,
            image_size=p["image_size"], image_checksum=p["image_checksum"],
            features={**defaults, **{k: v for k, v in p.items() if k not in _CORE_KEYS}},
            base=p.get("base", ""),
        )
    return dict(sorted(out.items()))


def use_profiles_file(path: str) -> None:
    """Judge by the builds ``path`` describes too, here and in every process started from now on.
    Raises :class:`~.profile_file.ProfileFileError` (one line per mistake) when the file is wrong."""
    from .profile_file import read_profile_file
    path = os.path.abspath(os.path.expanduser(path))
    read_profile_file(path, _raw())
    os.environ[PROFILES_ENV] = path
    load_profiles.cache_clear()


def profile_numbers() -> list:
    return list(load_profiles())


def get_profile(spec: int | str | None = None) -> Profile:
    """Profile by release number, ``R<n>`` name or ``latest``/None (the default).

    Raises ``KeyError`` with the list of known releases for anything else; use
    :func:`resolve_version` for version numbers that may be unknown.
    """
    profiles = load_profiles()
    if spec is None or str(spec).lower() in ("latest", "default", ""):
        return profiles[DEFAULT_FIRMWARE]
    s = str(spec).strip()
    for p in profiles.values():
        if s.upper() == p.name.upper():
            return p
    try:
        return profiles[int(s.split()[0])]
    except (ValueError, KeyError):
        known = ", ".join(f"{p.number} ({p.name})" for p in profiles.values())
        raise KeyError(f"unknown firmware {spec!r}; known releases: {known}, or 'latest'") from None


def resolve_version(number: int) -> tuple[Profile, bool]:
    """Profile for a version number seen on a target: (profile, exact).

    Unknown numbers use the nearest earlier release (exact=False) so the caller can
    say so; numbers before R1 use R1.
    """
    profiles = load_profiles()
    if number in profiles:
        return profiles[number], True
    earlier = [n for n in profiles if n < number]
    return profiles[max(earlier) if earlier else min(profiles)], False


@cache
def passive_signature_ids(table: str) -> tuple[dict, int, int, int]:
    """FIRMWARE-BEHAVIOUR.md#fb-debug-signatures: (signature -> passive ID, active mask, active value,
    active ID) of the passive-ID scan's table ``table`` (a profile's ``passive_signature_table``)."""
    raw = _raw()["passive_signature_tables"]
    ids = {int(sig, 16): pid for sig, pid in raw[table].items()}
    return ids, int(raw["active_mask"], 16), int(raw["active_value"], 16), int(raw["active_id"])


def neighbours(number: int) -> Optional[tuple[Profile, Profile]]:
    """For a build number between two known releases: (the release before it, the one after).

    None for a known release and for numbers before the first or after the last release (those
    have one neighbour, whose profile :func:`resolve_version` gives)."""
    profiles = load_profiles()
    if number in profiles:
        return None
    earlier = [n for n in profiles if n < number]
    later = [n for n in profiles if n > number]
    if not earlier or not later:
        return None
    return profiles[max(earlier)], profiles[min(later)]


def undecided_features(earlier: Profile, later: Profile) -> frozenset:
    """The feature keys on which two releases differ: for a build between them, unknown."""
    keys = set(earlier.features) | set(later.features)
    return frozenset(k for k in keys if earlier.features.get(k) != later.features.get(k))


def bootloader_data() -> dict:
    """Bootloader facts (FIRMWARE-BEHAVIOUR.md#fb-bootloader): prompt, command order, help text, limits."""
    return dict(_raw()["bootloader"])

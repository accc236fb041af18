"""A user's profiles file (``--profiles FILE``, docs/PROFILES.md): builds the package does not
know, each described as a known release it starts from and what it changes, checked with one line
per mistake (the file and the key), and turned into entries of the form ``profiles.json`` has.

protocol/profiles.py is the one loader: it merges these entries with the releases it knows, so the
emulator, the suite and the fuzzer (and the processes they start) see the same profiles.
"""
from __future__ import annotations

import json
from typing import Any, Dict, List, Mapping, Tuple

__all__ = ["ProfileFileError", "read_profile_file", "ENTRY_KEYS"]

#: keys of a build's entry besides the per-release behaviours: what each must hold
ENTRY_KEYS: Dict[str, str] = {
    "base": "the release it starts from: R1..R7 or its number",
    "name": "a short name for reports, e.g. R8-dev (not a known release's)",
    "version_string": "the text after `Firmware version: `, starting with the entry's number",
    "help_text": "its help text, a list of lines (default: the base's)",
    "commands": "its command table in matching order, a list of names (default: the base's)",
    "set_keywords": "its `set` keywords in matching order, a list (default: the base's)",
    "signature": "its 64-byte signature, 128 hex digits (default: none known)",
    "image_size": "its image's size in bytes (default: none known, 0)",
    "image_checksum": "its image's checksum (default: none known, 0)",
}
_REQUIRED = ("base", "name", "version_string")


class ProfileFileError(ValueError):
    """Mistakes in a profiles file: ``lines``, one per mistake, each naming the file and the key."""

    def __init__(self, lines: List[str]):
        super().__init__("\n".join(lines))
        self.lines = lines


def _type_name(value: Any) -> str:
    return {bool: "true or false", int: "a whole number", float: "a number", str: "a string",
            list: "a list", dict: "an object"}.get(type(value), type(value).__name__)


def _same_type(value: Any, like: Any) -> bool:
    if isinstance(like, bool) or isinstance(value, bool):
        return isinstance(value, bool) and isinstance(like, bool)
    if isinstance(like, (int, float)) and not isinstance(like, bool):
        return isinstance(value, (int, float)) and (isinstance(like, float) or isinstance(value, int))
    return isinstance(value, type(like))


def _strings(value: Any) -> bool:
    return isinstance(value, list) and all(isinstance(v, str) for v in value)


def _check_entry(where: str, number: str, entry: Any, raw: Mapping[str, Any],
                 names: Mapping[str, str], features: Mapping[str, Tuple[Any, frozenset]]) -> List[str]:
    """The mistakes of one entry (``where``: ``FILE: profiles.<number>``)."""
    if not number.isdigit():
        return [f"{where}: the key must be the build's version number (digits), as `version` prints it first"]
    if not isinstance(entry, dict):
        return [f"{where}: must be an object (base, name, version_string, what it changes)"]
    out = [f"{where}: missing `{key}` ({ENTRY_KEYS[key]})" for key in _REQUIRED if key not in entry]
    if int(number) in {int(n) for n in raw["profiles"]}:
        out.append(f"{where}: {number} is a known release's number ({names[number]}); describe a build "
                   "the package does not know")
    for key, value in entry.items():
        at = f"{where}.{key}"
        if key == "base":
            if str(value) not in names and str(value).upper() not in names.values():
                out.append(f"{at}: unknown base {value!r}; known releases: "
                           + ", ".join(f"{n} ({num})" for num, n in names.items()))
        elif key == "name":
            if not isinstance(value, str) or not value.strip() or " " in value:
                out.append(f"{at}: must be a short name without spaces, e.g. \"R8-dev\"")
            elif value.upper() in names.values():
                out.append(f"{at}: {value!r} is a known release's name; give the build a name of its own")
        elif key == "version_string":
            if not isinstance(value, str) or value.split()[:1] != [number]:
                out.append(f"{at}: must be a string starting with the entry's number {number}, "
                           f"e.g. \"{number} 2025-03-01T12:00:00+00:00\"")
        elif key in ("help_text", "commands", "set_keywords"):
            if not _strings(value) or not value:
                out.append(f"{at}: must be a list of strings ({ENTRY_KEYS[key]})")
        elif key == "signature":
            hexes = isinstance(value, str) and all(c in "0123456789abcdefABCDEF" for c in value)
            if not hexes or len(value) != 128:
                out.append(f"{at}: must be 128 hex digits (64 bytes)")
        elif key in ("image_size", "image_checksum"):
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                out.append(f"{at}: must be a whole number >= 0")
        elif key in features:
            like, seen = features[key]
            if not _same_type(value, like):
                out.append(f"{at}: wrong type: {_type_name(value)}, where the releases have "
                           f"{_type_name(like)} (e.g. {json.dumps(like)})")
            elif isinstance(value, str) and value not in seen:
                out.append(f"{at}: {value!r} is no behaviour the package models; one of: "
                           + ", ".join(sorted(seen)))
        elif not key.startswith("_"):
            out.append(f"{at}: unknown key; an entry takes {', '.join(ENTRY_KEYS)} or a per-release "
                       "behaviour (docs/PROFILES.md lists them)")
    return out


def _features(raw: Mapping[str, Any]) -> Dict[str, Tuple[Any, frozenset]]:
    """Every per-release behaviour a profile may change: its value in some release (or the model
    default), and the string values the releases have (the behaviours the package models)."""
    core = set(ENTRY_KEYS) | {"number", "help_text"}
    out: Dict[str, Tuple[Any, frozenset]] = {}
    defaults = {k: v for k, v in raw.get("model_defaults", {}).items() if not k.startswith("_")}
    for key, value in defaults.items():
        out[key] = (value, frozenset())
    for profile in raw["profiles"].values():
        for key, value in profile.items():
            if key in core:
                continue
            like, seen = out.get(key, (value, frozenset()))
            out[key] = (like, seen | ({value} if isinstance(value, str) else set()))
    return out


def read_profile_file(path: str, raw: Mapping[str, Any]) -> Dict[str, Dict[str, Any]]:
    """The entries of ``path`` as ``profiles.json`` entries (its help texts inline under
    ``help_lines``), checked against ``raw`` (the package's profiles.json). Raises
    :class:`ProfileFileError` listing every mistake, one line each."""
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except OSError as exc:
        raise ProfileFileError([f"{path}: cannot read it ({exc.strerror or exc})"]) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ProfileFileError([f"{path}: not JSON: {exc}"]) from None
    names = {num: p["name"] for num, p in raw["profiles"].items()}
    if not isinstance(data, dict) or not isinstance(data.get("profiles"), dict) or not data["profiles"]:
        raise ProfileFileError([f"{path}: must be an object whose `profiles` maps each build's version "
                                "number to what it is (docs/PROFILES.md)"])
    mistakes = [f"{path}: {key}: unknown key; the file takes `profiles` (and `_about`)"
                for key in data if key not in ("profiles",) and not key.startswith("_")]
    features = _features(raw)
    own_names: Dict[str, str] = {}
    for number, entry in data["profiles"].items():
        found = _check_entry(f"{path}: profiles.{number}", str(number), entry, raw, names, features)
        name = entry.get("name") if isinstance(entry, dict) else None
        if not found and name in own_names.values():
            found.append(f"{path}: profiles.{number}.name: {name!r} names another build of the file too")
        own_names[str(number)] = str(name)
        mistakes += found
    if mistakes:
        raise ProfileFileError(mistakes)
    return {number: _entry(entry, raw, names) for number, entry in data["profiles"].items()}


def _entry(entry: Mapping[str, Any], raw: Mapping[str, Any], names: Mapping[str, str]) -> Dict[str, Any]:
    """A checked entry as a profiles.json entry: the base's, with the entry's changes."""
    base_number = next(num for num, name in names.items()
                       if str(entry["base"]) == num or str(entry["base"]).upper() == name)
    base = dict(raw["profiles"][base_number])
    out = {k: v for k, v in base.items() if k not in ("signature", "image_size", "image_checksum")}
    out.update({"signature": None, "image_size": 0, "image_checksum": 0, "base": base["name"]})
    out["help_lines"] = list(raw["help_texts"][base["help_text"]])
    for key, value in entry.items():
        if key == "help_text":
            out["help_lines"] = list(value)
        elif key != "base" and not key.startswith("_"):
            out[key] = value
    out.pop("help_text", None)
    return out

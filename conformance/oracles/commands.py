"""Command-name resolution: the document's rule and the firmware's rule (FIRMWARE-BEHAVIOUR.md#fb-matching).

Both are computed from a command table (a profile's ``commands``), never from a hard-coded
list of answers, so a new release's table brings its own expectations.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Sequence, Tuple

__all__ = ["resolve", "shortest_resolving_prefix", "unique_prefix", "ambiguous_prefixes",
           "longer_tokens"]


def resolve(token: str, table: Sequence[str]) -> Optional[str]:
    """Firmware rule: the first name in table order of which ``token`` is a non-empty prefix."""
    if not token:
        return None
    return next((name for name in table if name.startswith(token)), None)


def shortest_resolving_prefix(name: str, table: Sequence[str]) -> str:
    """The shortest prefix of ``name`` the firmware resolves to ``name`` (maybe the full name)."""
    for n in range(1, len(name) + 1):
        if resolve(name[:n], table) == name:
            return name[:n]
    raise ValueError(f"{name!r} is shadowed by an earlier entry and can never be typed")


def unique_prefix(name: str, table: Sequence[str]) -> Optional[str]:
    """The document's rule: the shortest prefix no other name starts with (None if the name
    is itself a prefix of another name, e.g. ``pid`` next to ``pid_diff``)."""
    for n in range(1, len(name) + 1):
        p = name[:n]
        if all(not other.startswith(p) for other in table if other != name):
            return p
    return None


def ambiguous_prefixes(table: Sequence[str]) -> List[Tuple[str, str, Tuple[str, ...]]]:
    """Every prefix that starts two or more names: (prefix, what the firmware runs, all names)."""
    seen: Dict[str, Tuple[str, ...]] = {}
    for name in table:
        for n in range(1, len(name) + 1):
            p = name[:n]
            if p not in seen:
                seen[p] = tuple(o for o in table if o.startswith(p))
    return [(p, names[0], names) for p, names in sorted(seen.items()) if len(names) > 1
            and resolve(p, table) == names[0]]


def longer_tokens(table: Sequence[str]) -> List[str]:
    """A token one character longer than each name that no name starts with (``vinx``)."""
    out = []
    for name in table:
        for extra in "xz9_":
            tok = name + extra
            if resolve(tok, table) is None:
                out.append(tok)
                break
    return out

"""Known deviations per release, as data (``deviations.json``), and the judgement of one check.

The three outcomes the brief asks for: the target does what the document says -> pass; it
does what this release is known to do instead -> known deviation; anything else -> fail.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Dict, FrozenSet, Tuple

from ..protocol.behaviour import cite

__all__ = ["Deviation", "deviations", "deviation", "expected_keys"]


@dataclass(frozen=True)
class Deviation:
    key: str
    requirement: str
    behaviour: Tuple[str, ...]   # anchors of docs/FIRMWARE-BEHAVIOUR.md that explain it
    profiles: FrozenSet[str]
    document: str
    firmware: str
    explain: str = ""        # one sentence for the report: what the difference means to a host

    def applies_to(self, profile_name: str) -> bool:
        return profile_name in self.profiles

    @property
    def reference(self) -> str:
        """Where a reader finds the explanation: ``docs/FIRMWARE-BEHAVIOUR.md#fb-...``."""
        return cite(self.behaviour)


@lru_cache(maxsize=1)
def deviations() -> Dict[str, Deviation]:
    data = resources.files(__name__.rpartition(".")[0]).joinpath("deviations.json")   # in this package
    text = data.read_text(encoding="utf-8")
    raw = json.loads(text)["deviations"]
    return {key: Deviation(key, d["requirement"], tuple(d["behaviour"]), frozenset(d["profiles"]),
                           d["document"], d["firmware"], d.get("explain", "")) for key, d in raw.items()}


def deviation(key: str) -> Deviation:
    try:
        return deviations()[key]
    except KeyError:
        raise KeyError(f"no known deviation {key!r} in conformance/deviations.json") from None


def expected_keys(profile_name: str) -> Tuple[str, ...]:
    """Every deviation key deviations.json lists for this release."""
    return tuple(sorted(k for k, d in deviations().items() if d.applies_to(profile_name)))

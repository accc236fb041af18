"""What the reference model (fuzz/model/reference_model.py) predicts a HAT prints: :class:`Expect` items, and
what each CR-terminated line did (:class:`LineFate`). fuzz/oracles/stream_match.py matches a target's answer
against them."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import List, Optional

from ..oracles.built_in import FATE, STATE

__all__ = ["Expect", "LineFate", "joined", "exact_item", "prompt_item", "error_item", "CRLF_ITEM", "VIN_ITEM",
           "SIGNATURE_ITEM", "LISTING_ITEM"]


@dataclass(frozen=True)
class Expect:
    """One piece of predicted output.

    ``exact``: these bytes. ``pattern``: one CRLF-terminated line matching this regex.
    ``listing``: the ``list`` dump (4 port headers with active-device blocks). ``oracle`` says
    which oracle a mismatch here belongs to (prompt and echo bytes show state; outputs show fate).
    """

    kind: str                     # "exact" | "pattern" | "listing"
    data: bytes = b""
    pattern: str = ""
    oracle: str = FATE.name
    what: str = ""

    def describe(self) -> str:
        if self.kind == "exact":
            return f"{self.what or 'bytes'} {self.data!r}"
        if self.kind == "pattern":
            return f"{self.what} line /{self.pattern}/"
        return "list dump of ports 0..3"


def exact_item(data: bytes, what: str, oracle: str = FATE.name) -> Expect:
    return Expect("exact", data=data, oracle=oracle, what=what)


# Items predicted over and over, made once (Expect is frozen; H10 profile: building them was a
# visible share of a prediction).
CRLF_ITEM = exact_item(b"\r\n", "CRLF after CR")
VIN_ITEM = Expect("pattern", pattern=r"\d+\.\d\d V", what="vin")
SIGNATURE_ITEM = Expect("pattern", pattern=r"Firmware signature:( [0-9A-F]{2}){64}", what="signature")
LISTING_ITEM = Expect("listing")


@lru_cache(maxsize=16)
def prompt_item(port: int) -> Expect:
    return exact_item(f"P{port}>".encode(), "prompt", STATE.name)


@lru_cache(maxsize=1024)
def error_item(failed: str) -> Expect:
    return exact_item(b"Error\r\n", f"Error (from {failed!r})")


@dataclass
class LineFate:
    """What one CR-terminated line did according to the model."""

    raw: bytes                    # the stored line (after editing and the 256-byte limit)
    commands: List[str] = field(default_factory=list)   # resolved names that completed
    failed: Optional[str] = None  # the command (or unknown token) that printed Error
    unknown: Optional[str] = None  # set when the failure was a token that matched no command
    comment: bool = False
    unspecified: List[str] = field(default_factory=list)

    @property
    def error(self) -> bool:
        return self.failed is not None


def joined(first: List[Expect], second: List[Expect]) -> List[Expect]:
    """The prediction for two inputs fed at once, from the predictions for each in turn: an
    unfinished line's echo that runs on into the second is one item, as :meth:`ReferenceModel.feed`
    of both would give (the echo only changes at a CR, which ends a run)."""
    if first and second and first[-1].what == "echo" and second[0].what == "echo":
        return first[:-1] + [exact_item(first[-1].data + second[0].data, "echo", STATE.name)] + second[1:]
    return first + second

"""One step as the model predicts it: the inputs sent back to back and a fence, the answer
they should get and the port states it is judged by (:func:`plan_step`); and the cut of a run's
inputs into steps whose answer fits a HAT's TX ring (:func:`output_groups`). The runner sends and
checks what is planned here; nothing here touches a target.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Sequence, Set, Tuple

from ..running.target_exchange import FENCE
from .expect import Expect, LineFate, joined
from .port_model import PortModel
from .reference_model import ReferenceModel

__all__ = ["DEBUG_OFF", "StepPlan", "plan_step", "output_groups", "LISTING_MAX"]

# Debug bit 1 is a raw serial trace with no line structure (fb-debug): after any input that leaves
# it set, this is sent at once so the line-level oracles stay meaningful.
DEBUG_OFF = b"debug 0\r"


def _count_fences(items: Sequence[Expect]) -> int:
    return sum(1 for it in items if it.kind == "exact" and it.what == "version line")


# A `list` dump's size depends on the devices: 4000 bytes is a typical guess (four motors print about
# 4,300), LISTING_MAX what four of the largest device of the catalogue print (about 1,870 bytes each):
# the bound the TX ring must be judged by (fuzz/model/tx_ring.py).
LISTING_GUESS = 4000
LISTING_MAX = 4 * 1900


def _size(items: Sequence[Expect], listing: int = LISTING_GUESS) -> int:
    return sum(len(it.data) if it.kind == "exact" else (listing if it.kind == "listing" else 80)
               for it in items)


@dataclass
class StepPlan:
    """One step as the model predicts it: its inputs sent back to back, then one fence. Its
    answer (and any line printed meanwhile) is judged by the port states before, between and
    after the inputs, and the debug bits of any of them."""

    datas: List[bytes]            # the inputs as sent (with DEBUG_OFF where the guard added it)
    expected: List[Expect]        # the answer to all of them, up to and with the fence's
    states: List[List[PortModel]]  # the ports before the step and after each line of each input
    debug: int
    fates: List[LineFate]         # every line the step ends, the fence's included

    @property
    def blob(self) -> bytes:
        return b"".join(self.datas) + FENCE

    @property
    def fences(self) -> int:
        return max(1, _count_fences(self.expected))

    @property
    def size(self) -> int:
        """Bytes the step is predicted to print (an upper guess for lists and patterns)."""
        return _size(self.expected)

    @property
    def size_max(self) -> int:
        """The most the step may print (a `list` dump at its largest)."""
        return _size(self.expected, LISTING_MAX)


def _lines(data: bytes) -> List[bytes]:
    """``data`` cut after each CR (the model reads it the same in pieces or whole)."""
    pieces = [piece + b"\r" for piece in data.split(b"\r")]
    pieces[-1] = pieces[-1][:-1]
    return [piece for piece in pieces if piece] or [data]


def plan_step(model: ReferenceModel, datas: Sequence[bytes], guard: int = 0) -> StepPlan:
    """Feed ``datas`` and the fence to ``model`` (it moves on). With ``guard`` (debug bits; True
    is bit 1), :data:`DEBUG_OFF` is appended to each input that leaves one of them set (and fed)."""
    states = [[p.copy() for p in model.ports]]
    model.debug_seen = model.debug
    expected: List[Expect] = []
    fates: List[LineFate] = []
    sent: List[bytes] = []
    for data in datas:
        # One state per line, not per input: on a wire a report may come between two lines of
        # one input (a `selonce` answered before the next line has arrived, fb-selonce-immediate).
        items: List[Expect] = []
        more_fates: List[LineFate] = []
        for line in _lines(data):
            got, got_fates = model.feed(line)
            items, more_fates = joined(items, got), more_fates + got_fates
            states.append([p.copy() for p in model.ports])
        if model.debug & guard:
            data += DEBUG_OFF
            more, off_fates = model.feed(DEBUG_OFF)
            items = joined(items, more)          # what feeding ``data + DEBUG_OFF`` at once predicts
            more_fates += off_fates
        if expected and items and expected[-1].what == "echo" and items[0].what == "echo":
            expected = joined(expected, items)
        else:
            expected += items
        fates += more_fates
        sent.append(data)
    fence_items, fence_fates = model.feed(FENCE)
    # Every bit any line of the step set, however briefly (a guard's `debug 0` included).
    return StepPlan(sent, joined(expected, fence_items), states, model.debug_seen, fates + fence_fates)


def output_groups(model: ReferenceModel, datas: Sequence[bytes], limit: int) -> Tuple[List[List[bytes]],
                                                                                      Set[int]]:
    """``datas`` cut into consecutive groups whose predicted output stays within ``limit``
    bytes (beyond what they send): a HAT drops output once its TX ring is full (fb-tx-ring), and on a
    115200-baud wire input arrives no faster than output leaves. An input whose own answer is
    over the limit (``help`` twice on one line) is left out: which of its bytes a HAT drops
    depends on timing no model predicts. Returns the groups and the indices of those left out;
    ``model`` is not changed."""
    probe = model.clone()
    groups: List[List[bytes]] = [[]]
    grow = 0
    left_out: Set[int] = set()
    for i, data in enumerate(datas):
        before = probe.clone()
        items, _fates = probe.feed(data)
        more = _size(items) - len(data)
        if more > limit:
            probe = before
            left_out.add(i)
            continue
        if groups[-1] and grow + more > limit:
            groups.append([])
            grow = 0
        groups[-1].append(data)
        grow += max(more, 0)
    return [g for g in groups if g], left_out

"""State kept per target object across runs (fuzz/oracles/differential_memory.py)."""
from __future__ import annotations

import gc
from types import SimpleNamespace

from buildhat_conformance.fuzz.oracles.differential_memory import PerTarget


class _Target:
    """A stand-in for a kept-open target (weakly referenceable, as the real ones are)."""


def test_each_target_object_has_its_own_state_made_once():
    made = []
    per = PerTarget(lambda: made.append(1) or set())
    a, b = _Target(), _Target()
    per(a).add(1)
    assert per(a) == {1} and per(b) == set() and len(made) == 2
    # a target opened anew (another object) starts with none; the old one's state goes with it
    del a
    gc.collect()
    assert len(per._by_target) == 1


def test_a_target_that_cannot_be_weakly_referenced_is_kept_by_identity():
    per = PerTarget(set)
    a = SimpleNamespace()
    per(a).add(2)
    assert per(a) == {2} and per(SimpleNamespace()) == set()

"""What the differential oracle keeps about one HAT across runs: state tied to a target object.

A target kept open from run to run (a process, a HAT, the firmware in the loop) carries what an earlier
run did into the next (a port still setting up, a set-up that lost messages), while each run has a
new :class:`~.runner.Runner`. Such state is kept here, per target object, for as long as that object
lives: a target opened anew starts with none.
"""
from __future__ import annotations

from typing import Callable, Dict, Generic, Tuple, TypeVar
from weakref import WeakKeyDictionary

__all__ = ["PerTarget"]

T = TypeVar("T")


class PerTarget(Generic[T]):
    """``per(target)``: the state of ``target``, made by ``make()`` the first time it is asked for."""

    def __init__(self, make: Callable[[], T]):
        self._make = make
        self._by_target: WeakKeyDictionary[object, T] = WeakKeyDictionary()
        self._by_id: Dict[int, Tuple[object, T]] = {}     # targets that cannot be weakly referenced

    def __call__(self, target: object) -> T:
        try:
            state = self._by_target.get(target)
            if state is None:
                state = self._by_target[target] = self._make()
            return state
        except TypeError:
            kept = self._by_id.get(id(target))
            if kept is None or kept[0] is not target:
                if len(self._by_id) >= 64:          # (such a target is held here: keep only the recent ones)
                    self._by_id.clear()
                kept = self._by_id[id(target)] = (target, self._make())
            return kept[1]

"""Bounded histories for a session: the last events and bytes, indexed from the session's start.

A session used to keep every event and byte, so a HAT streaming 3,000 lines/s grew the harness
without bound (issue 13: 523 MB). The transcript on disk is the complete record; in memory only
the recent past is needed (a test looks back over its own case, a few seconds). Positions stay
absolute (``len()`` counts everything ever added), so marks taken earlier remain valid; items
older than the bound are gone, and slices that reach back before them start at the oldest kept.
"""
from __future__ import annotations

from typing import Callable, Generic, Iterator, List, Optional, TypeVar, Union, overload

__all__ = ["EventHistory", "ByteHistory", "MAX_EVENTS", "MAX_BYTES"]

T = TypeVar("T")

# Enough for any case of the suite many times over (a `list` with four devices is < 100 lines; a
# long case at 3,000 lines/s for 5 s is 15,000), and for the bytes they hold: an event is a line
# (at most 1 KiB, see events.LineSplitter), so the bytes bound is what limits garbage.
MAX_EVENTS = 20_000
MAX_EVENT_BYTES = 8 * 1024 * 1024
MAX_BYTES = 8 * 1024 * 1024


class EventHistory(Generic[T]):
    """A list with absolute indices that forgets its oldest items beyond ``limit``."""

    def __init__(self, limit: int = MAX_EVENTS, weigh: Optional[Callable[[T], int]] = None,
                 max_weight: int = MAX_EVENT_BYTES):
        self.limit = max(1, int(limit))
        self._items: List[T] = []
        self.dropped = 0                  # how many items were forgotten (the index of _items[0])
        self._weigh = weigh
        self._weights: List[int] = []
        self._weight = 0
        self.max_weight = max_weight

    def __len__(self) -> int:
        return self.dropped + len(self._items)

    def append(self, item: T) -> None:
        self.extend([item])

    def extend(self, items: List[T]) -> None:
        self._items.extend(items)
        if self._weigh is not None:
            weights = [self._weigh(i) for i in items]
            self._weights.extend(weights)
            self._weight += sum(weights)
        self._trim()

    def _trim(self) -> None:
        # Trim in chunks (a quarter of the bound) so that deleting from the front stays amortised O(1).
        excess = len(self._items) - self.limit
        if self._weigh is not None and self._weight > self.max_weight:
            total, n = self._weight, 0
            while total > self.max_weight * 3 // 4 and n < len(self._items) - 1:
                total -= self._weights[n]
                n += 1
            excess = max(excess, n if n > 0 else 0)
        elif excess <= self.limit // 4:
            return
        if excess <= 0:
            return
        del self._items[:excess]
        if self._weigh is not None:
            self._weight -= sum(self._weights[:excess])
            del self._weights[:excess]
        self.dropped += excess

    def scan(self, pred: Callable[[T], bool], start: int) -> Optional[int]:
        """Absolute index of the first kept item from ``start`` on that satisfies ``pred``."""
        items, base = self._items, self.dropped
        for k in range(max(0, start - base), len(items)):
            if pred(items[k]):
                return k + base
        return None

    @overload
    def __getitem__(self, index: int) -> T: ...

    @overload
    def __getitem__(self, index: slice) -> List[T]: ...

    def __getitem__(self, index: Union[int, slice]) -> Union[T, List[T]]:
        if isinstance(index, slice):
            start, stop, step = index.indices(len(self))
            return self._items[max(0, start - self.dropped):max(0, stop - self.dropped):step]
        if index < 0:
            index += len(self)
        if index < self.dropped:
            raise IndexError(f"event {index} is no longer kept in memory (the transcript has it)")
        return self._items[index - self.dropped]

    def __iter__(self) -> Iterator[T]:
        return iter(list(self._items))

    def __bool__(self) -> bool:
        return bool(self._items)

    def __eq__(self, other: object) -> bool:
        return list(self._items) == other if isinstance(other, list) else NotImplemented

    __hash__ = None  # type: ignore[assignment]


class ByteHistory:
    """Bytes with absolute offsets that forgets its oldest bytes beyond ``limit``."""

    def __init__(self, limit: int = MAX_BYTES):
        self.limit = max(1, int(limit))
        self._data = bytearray()
        self.dropped = 0

    def __len__(self) -> int:
        return self.dropped + len(self._data)

    def __iadd__(self, data: bytes) -> ByteHistory:
        self._data += data
        excess = len(self._data) - self.limit
        if excess > self.limit // 4:
            del self._data[:excess]
            self.dropped += excess
        return self

    def __getitem__(self, index: Union[int, slice]) -> Union[int, bytes]:
        if isinstance(index, slice):
            start, stop, step = index.indices(len(self))
            return bytes(self._data[max(0, start - self.dropped):max(0, stop - self.dropped):step])
        if index < 0:
            index += len(self)
        if index < self.dropped:
            raise IndexError(f"byte {index} is no longer kept in memory (the transcript has it)")
        return self._data[index - self.dropped]

    def __bytes__(self) -> bytes:
        return bytes(self._data)

    def find(self, sub: bytes, start: int = 0) -> int:
        """Absolute offset of ``sub`` from ``start`` on, or -1."""
        i = self._data.find(sub, max(0, start - self.dropped))
        return -1 if i < 0 else i + self.dropped

    def endswith(self, suffix: bytes) -> bool:
        return self._data.endswith(suffix)

    def count(self, sub: bytes) -> int:
        return self._data.count(sub)

    def __contains__(self, sub: bytes) -> bool:
        return sub in self._data

    def __eq__(self, other: object) -> bool:
        if isinstance(other, (bytes, bytearray)):
            return bytes(self._data) == bytes(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

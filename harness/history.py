"""Bounded histories for a session: the last events and bytes, indexed from the session's start.

A session used to keep every event and byte, so a HAT streaming 3,000 lines/s grew the harness
without bound (issue 13: 523 MB). The transcript on disk is the complete record; in memory only
the recent past is needed (a test looks back over its own case, a few seconds). Positions stay
absolute (``len()`` counts everything ever added), so marks taken earlier remain valid; items
older than the bound are gone, and slices that reach back before them start at the oldest kept.
"""
from __future__ import annotations

from typing import Callable, Generic, Iterator, List, Optional, Tuple, TypeVar, Union, overload

__all__ = ["EventHistory", "ByteHistory", "MAX_EVENTS", "MAX_BYTES"]

T = TypeVar("T")

# Enough for any case of the suite many times over (a `list` with four devices is < 100 lines; a
# long case at 3,000 lines/s for 5 s is 15,000), and for the bytes they hold: an event is a line
# (at most 1 KiB, see line_splitter.LineSplitter), so the bytes bound is what limits garbage.
MAX_EVENTS = 20_000
MAX_EVENT_BYTES = 8 * 1024 * 1024
MAX_BYTES = 8 * 1024 * 1024


class EventHistory(Generic[T]):
    """A list with absolute indices that forgets its oldest items beyond ``limit``."""

    def __init__(self, limit: int = MAX_EVENTS, weigh: Optional[Callable[[T], int]] = None,
                 max_weight: int = MAX_EVENT_BYTES):
        self.limit = max(1, int(limit))
        # (how many items were forgotten, the items kept): one attribute, replaced whole when
        # trimming, so a reader in another thread never sees a count and a list that disagree.
        self._state: Tuple[int, List[T]] = (0, [])
        self._weigh = weigh
        self._weights: List[int] = []
        self._weight = 0
        self.max_weight = max_weight

    @property
    def dropped(self) -> int:
        return self._state[0]

    @property
    def _items(self) -> List[T]:
        return self._state[1]

    def __len__(self) -> int:
        dropped, items = self._state
        return dropped + len(items)

    def append(self, item: T) -> None:
        self.extend([item])

    def extend(self, items: List[T]) -> None:
        self._state[1].extend(items)
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
        dropped, kept = self._state
        self._state = (dropped + excess, kept[excess:])
        if self._weigh is not None:
            self._weight -= sum(self._weights[:excess])
            del self._weights[:excess]

    def scan(self, pred: Callable[[T], bool], start: int) -> Optional[int]:
        """Absolute index of the first kept item from ``start`` on that satisfies ``pred``."""
        base, items = self._state
        for k in range(max(0, start - base), len(items)):
            if pred(items[k]):
                return k + base
        return None

    @overload
    def __getitem__(self, index: int) -> T: ...

    @overload
    def __getitem__(self, index: slice) -> List[T]: ...

    def __getitem__(self, index: Union[int, slice]) -> Union[T, List[T]]:
        dropped, items = self._state
        if isinstance(index, slice):
            start, stop, step = index.indices(dropped + len(items))
            return items[max(0, start - dropped):max(0, stop - dropped):step]
        if index < 0:
            index += dropped + len(items)
        if index < dropped:
            raise IndexError(f"event {index} is no longer kept in memory (the transcript has it)")
        return items[index - dropped]

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
        # (bytes forgotten, bytes kept), replaced whole when trimming (see EventHistory).
        self._state: Tuple[int, bytearray] = (0, bytearray())

    @property
    def dropped(self) -> int:
        return self._state[0]

    @property
    def _data(self) -> bytearray:
        return self._state[1]

    def __len__(self) -> int:
        dropped, data = self._state
        return dropped + len(data)

    def __iadd__(self, data: bytes) -> ByteHistory:
        dropped, kept = self._state
        kept += data
        excess = len(kept) - self.limit
        if excess > self.limit // 4:
            self._state = (dropped + excess, kept[excess:])
        return self

    def __getitem__(self, index: Union[int, slice]) -> Union[int, bytes]:
        dropped, data = self._state
        if isinstance(index, slice):
            start, stop, step = index.indices(dropped + len(data))
            return bytes(data[max(0, start - dropped):max(0, stop - dropped):step])
        if index < 0:
            index += dropped + len(data)
        if index < dropped:
            raise IndexError(f"byte {index} is no longer kept in memory (the transcript has it)")
        return data[index - dropped]

    def __bytes__(self) -> bytes:
        return bytes(self._data)

    def find(self, sub: bytes, start: int = 0) -> int:
        """Absolute offset of ``sub`` from ``start`` on, or -1."""
        dropped, data = self._state
        i = data.find(sub, max(0, start - dropped))
        return -1 if i < 0 else i + dropped

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

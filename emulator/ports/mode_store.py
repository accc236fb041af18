"""The per-mode payload store of one port (FIRMWARE-BEHAVIOUR.md#fb-data, #fb-pid).

Each DATA message from the active device overwrites the start of its mode's 132-byte buffer
(offsets up to 127 plus a 4-byte value) and records how long it was; the rest of the buffer
keeps what earlier, longer messages left. The report engine (emulator/ports/data_reports.py) reads the
buffer and the length; the motor controller's sensor variables read the buffer as it was when the
millisecond began (:meth:`ModeStore.at_tick_start`). The store is emptied when an active device
starts connecting.
"""
from __future__ import annotations

from typing import Dict, Optional, Tuple

__all__ = ["ModeStore", "MODE_BUFFER"]

MODE_BUFFER = 132


class ModeStore:
    def __init__(self) -> None:
        self._data: Dict[int, bytearray] = {}
        self._length: Dict[int, int] = {}
        # mode -> (the ms of its first store in that ms, the buffer before it; None: no data)
        self._before: Dict[int, Tuple[int, Optional[bytes]]] = {}

    def clear(self) -> None:
        self._data.clear()
        self._length.clear()
        self._before.clear()

    def store(self, mode: int, payload: bytes, now: Optional[int] = None) -> None:
        """A DATA message for ``mode`` handled in millisecond ``now`` (it arrived during it)."""
        buf = self._data.get(mode)
        if now is not None and self._before.get(mode, (None,))[0] != now:
            self._before[mode] = (now, None if buf is None else bytes(buf))
        if buf is None:
            buf = self._data[mode] = bytearray(MODE_BUFFER)
        buf[:len(payload)] = payload
        self._length[mode] = len(payload)

    def at_tick_start(self, mode: int, now: int) -> Optional[bytes]:
        """The padded buffer of ``mode`` as the firmware's timer pass at the start of millisecond
        ``now`` sees it: what messages that arrived during ``now`` stored comes after that pass
        (docs/EMULATOR-MODELS.md "Controller"). None if there was no data then."""
        before = self._before.get(mode)
        if before is not None and before[0] == now:
            return before[1]
        return self.latest(mode)

    def latest(self, mode: int) -> Optional[bytes]:
        """The padded buffer of ``mode``, None if nothing arrived for it since the last clear."""
        buf = self._data.get(mode)
        return None if buf is None else bytes(buf)

    def stored(self, mode: int) -> Tuple[bytes, int]:
        """(buffer, received length) of ``mode``; zeros and 0 when nothing arrived."""
        buf = self._data.get(mode)
        if buf is None:
            return bytes(MODE_BUFFER), 0
        return bytes(buf), self._length.get(mode, 0)

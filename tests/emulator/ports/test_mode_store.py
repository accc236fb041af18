"""The per-mode payload store (emulator/ports/mode_store.py): a DATA message overwrites the start of its
mode's buffer and the rest keeps what longer messages left (FIRMWARE-FACTS §6.1, §7.2); a new
connection empties it."""
from __future__ import annotations

from buildhat_conformance.emulator.ports.mode_store import ModeStore


def test_a_shorter_message_keeps_the_tail_of_a_longer_one():
    store = ModeStore()
    store.store(2, bytes([1, 2, 3, 4]))
    store.store(2, bytes([9]))
    buf, length = store.stored(2)
    assert buf[:4] == bytes([9, 2, 3, 4]) and length == 1
    assert store.latest(2) == buf


def test_modes_are_apart_and_an_unheard_mode_is_zeros():
    store = ModeStore()
    store.store(0, b"\x05")
    buf, length = store.stored(1)
    assert length == 0 and not any(buf) and len(buf) >= 128      # offsets up to 127 reach into it
    assert store.latest(1) is None and store.latest(0) is not None


def test_clear_forgets_everything():
    store = ModeStore()
    store.store(3, b"\x01\x02")
    store.clear()
    assert store.latest(3) is None and store.stored(3)[1] == 0


def test_the_controllers_see_the_buffer_as_the_millisecond_began():
    # issue 37: the firmware's timer pass (the PID) runs at the start of its millisecond, before a
    # message that arrives during it is handled (the firmware in the loop, pid-tick.script).
    def first(buf):
        assert buf is not None
        return buf[:1]

    store = ModeStore()
    store.store(2, b"\x01", now=10)
    assert store.at_tick_start(2, 10) is None                   # nothing before the first message
    assert first(store.at_tick_start(2, 11)) == b"\x01"
    store.store(2, b"\x02", now=20)
    store.store(2, b"\x03", now=20)                             # two in one ms: the one before both
    assert first(store.at_tick_start(2, 20)) == b"\x01"
    assert first(store.at_tick_start(2, 21)) == b"\x03" and first(store.latest(2)) == b"\x03"
    store.clear()
    assert store.at_tick_start(2, 20) is None

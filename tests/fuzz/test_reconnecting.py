"""Ports a side is setting up again, by that side's own clock (fuzz/reconnecting.py)."""
from __future__ import annotations

from buildhat_conformance.fuzz.reconnecting import WINDOW_MS, Reconnecting
from buildhat_conformance.harness.events import classify


def test_a_disconnect_starts_a_set_up_and_established_ends_it():
    tracker = Reconnecting(2)
    assert tracker.ports([0.0, 0.0]) == frozenset()
    tracker.feed(0, [classify(b"P0: timeout during data phase: disconnecting"), classify(b"P0: disconnected"),
                     classify(b"P3M0: 5")], 10.0)
    assert tracker.ports([20.0, 0.0]) == {0}
    tracker.feed(0, [classify(b"P0: established serial communication with active ID 30")], 2000.0)
    assert tracker.ports([2000.0, 0.0]) == frozenset()


def test_a_set_up_that_never_ends_is_compared_again_after_its_window():
    tracker = Reconnecting(2)
    tracker.feed(1, [classify(b"P2: disconnected")], 100.0)
    assert tracker.ports([0.0, 100.0 + WINDOW_MS]) == {2}
    assert tracker.ports([0.0, 100.0 + WINDOW_MS + 1]) == frozenset()
    # each side's own clock; a passive device's connect line ends it too
    tracker.feed(0, [classify(b"P1: connecting to active device")], 50.0)
    assert tracker.ports([60.0, 0.0]) == {1}
    tracker.feed(0, [classify(b"P1: connected to passive ID 8")], 70.0)
    assert tracker.ports([80.0, 0.0]) == frozenset()

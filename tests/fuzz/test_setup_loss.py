"""Ports whose set-up a side took only in part (fuzz/oracles/setup_loss.py), and the differential oracle's
use.

The sil finding (`--against emulator --seed 5 --jobs 2`, 20 s): the firmware dropped the motor after
500 ms without data and set it up again at 2400 baud; meanwhile a step sent the motor frames (`write2`,
`selonce`...), each waiting for the last to cross the 2400-baud wire, so that main-loop pass took
301 ms (`deltat=0000012D`) and the port's 4-slot message queue overran (`MQ overrun!`). From then on,
in that run and the next runs on the kept-open target, the firmware listed the motor without its mode 4
and mode 5 without its SI range, symbol and format; the emulator listed all of it.
"""
from __future__ import annotations

from types import SimpleNamespace

from buildhat_conformance.fuzz.oracles.setup_loss import SetupLoss, for_target
from buildhat_conformance.fuzz.running.checked_run import Runner, Stats
from buildhat_conformance.harness.events import classify

WHOLE = (b"P0: connected to active ID 30\r\ntype 30\r\n  nmodes =5\r\n"
         b"  M4 CALIB SI = CAL\r\n    format count=3 type=1 chars=5 dp=0\r\n"
         b"  M5 STATS SI = MIN\r\n    format count=14 type=1 chars=5 dp=0\r\n"
         b"P1: no device detected\r\nP2: connected to passive ID 8\r\nP3: no device detected\r\n")
PARTIAL = (b"P0: connected to active ID 30\r\ntype 30\r\n  nmodes =5\r\n"
           b"  M5 STATS SI = \r\n    format count=0 type=0 chars=0 dp=0\r\n"
           b"P1: no device detected\r\nP2: connected to passive ID 8\r\nP3: no device detected\r\n")
SET_UP_WITH_OVERRUN = (b"P0: connecting to active device\r\nMQ overrun!\r\nMQ overrun!\r\n"
                       b"deltat=0000012D\r\nset baud rate to 115200\r\n"
                       b"P0: established serial communication with active ID 30\r\n")


def _events(text: bytes):
    return [classify(line) for line in text.split(b"\r\n") if line]


def test_an_overrun_while_a_port_sets_up_marks_it_until_its_next_set_up():
    loss = SetupLoss()
    loss.feed(_events(SET_UP_WITH_OVERRUN))
    assert loss.ports() == {0}
    loss.feed(_events(b"P0: timeout during data phase: disconnecting\r\nP0: disconnected\r\n"))
    assert loss.ports() == {0}                 # the HAT still has what it took
    loss.feed(_events(b"P0: connecting to active device\r\n"))
    assert loss.ports() == frozenset()         # a new set-up: compared again once established


def test_an_overrun_outside_a_set_up_marks_no_port():
    """In the data phase a dropped message is a report, which is not compared anyway."""
    loss = SetupLoss()
    loss.feed(_events(b"MQ overrun!\r\nP0: connecting to active device\r\n"
                      b"P0: established serial communication with active ID 30\r\nMQ overrun!\r\n"))
    assert loss.ports() == frozenset()
    # every port setting up at the overrun (the line names none)
    loss.feed(_events(b"P1: connecting to active device\r\nP3: connecting to active device\r\n"
                      b"P3: checksum error: disconnecting\r\nMQ overrun!\r\n"))
    assert loss.ports() == {1}


class _Target:
    """A stand-in for a kept-open target (the loss is kept per target object)."""


def _runner(targets) -> Runner:
    runner = Runner.__new__(Runner)
    runner.sides = [SimpleNamespace(fence_line=b"Firmware version: x", label=label,   # type: ignore[assignment]
                                    link=SimpleNamespace(now=0.0, target_now=0.0, target=target))
                    for label, target in zip(("target", "against"), targets)]
    runner.stats, runner._apart = Stats(), set()
    runner.found = []              # type: ignore[attr-defined]
    runner.fail = (lambda oracle, message, details:         # type: ignore[method-assign]
                   runner.found.append(oracle))             # type: ignore[attr-defined]
    return runner


def test_the_runner_does_not_compare_a_port_whose_set_up_one_side_took_in_part():
    targets = (_Target(), _Target())
    runner = _runner(targets)
    runner._differential([b"list\r"], [PARTIAL, WHOLE])
    assert runner.found == ["differential"]              # type: ignore[attr-defined]
    runner._track(runner.sides[0], SET_UP_WITH_OVERRUN)  # type: ignore[arg-type]
    runner._differential([b"list\r"], [PARTIAL, WHOLE])
    assert runner.found == ["differential"] and runner.stats.setup_loss_apart == 1   # type: ignore[attr-defined]
    # another port's difference still counts
    other = WHOLE.replace(b"P3: no device detected", b"P3: connected to active ID 3D")
    runner._differential([b"list\r"], [PARTIAL, other])
    assert runner.found == ["differential"] * 2           # type: ignore[attr-defined]
    # the next run on the same kept-open targets (a new Runner) still knows
    later = _runner(targets)
    later._differential([b"list\r"], [PARTIAL, WHOLE])
    assert later.found == []                              # type: ignore[attr-defined]
    # fresh targets know nothing of it
    fresh = _runner((_Target(), _Target()))
    fresh._differential([b"list\r"], [PARTIAL, WHOLE])
    assert fresh.found == ["differential"]                # type: ignore[attr-defined]


def test_a_target_that_cannot_be_weakly_referenced_keeps_its_loss_too():
    target = SimpleNamespace()
    for_target(target).feed(_events(SET_UP_WITH_OVERRUN))
    assert for_target(target).ports() == {0}
    assert for_target(SimpleNamespace()).ports() == frozenset()


def test_a_parted_light_matrix_behind_a_partial_set_up_is_still_a_timing_boundary():
    """Seen in the campaign after the fix: with port 0 left out, the next difference was port 1's
    light matrix, gone on the firmware's side only; it must be found a parted matrix as it would be first."""
    runner = _runner((_Target(), _Target()))
    runner._track(runner.sides[0], SET_UP_WITH_OVERRUN)  # type: ignore[arg-type]
    matrix = b"P1: connected to active ID 40\r\ntype 40\r\n"
    with_matrix = WHOLE.replace(b"P1: no device detected\r\n", matrix)
    runner._differential([b"list\r"], [PARTIAL, with_matrix])
    assert runner.found == [] and runner._apart == {1}    # type: ignore[attr-defined]
    assert runner.stats.matrix_apart == 1 and runner.stats.setup_loss_apart == 1

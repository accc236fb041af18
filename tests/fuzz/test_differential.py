"""Differential mode: the same input to two targets; a difference (beyond analogue tolerance) is a finding."""
from __future__ import annotations

import argparse
from types import SimpleNamespace

from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.fuzz import cli
from buildhat_conformance.fuzz.findings.replay import replay_script
from buildhat_conformance.fuzz.findings.shrink import steps_of
from buildhat_conformance.fuzz.oracles.differential import (
    compare_answers,
    first_difference,
    open_dump,
    parted_matrix,
)
from buildhat_conformance.fuzz.running import from_arguments
from buildhat_conformance.fuzz.running.checked_run import Runner, Stats
from buildhat_conformance.protocol.profiles import get_profile
from buildhat_conformance.transcripts.script import load_script

EMPTY = {0: None, 1: None, 2: None, 3: None}


def test_compare_answers_tolerates_analogue_values_only():
    assert compare_answers(b"\r\n7.20 V\r\n", b"\r\n7.25 V\r\n") is None
    assert compare_answers(b"\r\n7.20 V\r\n", b"\r\n8.00 V\r\n") is not None
    assert compare_answers(b"\r\nError\r\n", b"\r\n") is not None
    # asynchronous lines depend on timing and are left to each side's own oracles
    assert compare_answers(b"\r\nP0M1: +5\r\nError\r\n", b"\r\nError\r\n") is None
    assert compare_answers(b"\r\nP0>", b"\r\nP1>") is not None


def _args(tmp_path, *extra):
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    args = parser.parse_args(["--target", "inprocess", "--out", str(tmp_path), "--no-database", "--quiet",
                              "--waits", "", *extra])
    args.devices = EMPTY
    return args


def _opener(release):
    return lambda: InProcessTarget(release, devices=EMPTY)


def test_two_copies_of_one_release_agree(tmp_path):
    args = _args(tmp_path, "--target", "inprocess:R7", "--against", "inprocess:R7", "--budget", "4x",
                 "--seed", "5", "--steps", "8")
    result, _files = from_arguments.run(args, primary=_opener("R7"), secondary=_opener("R7"))
    assert not result.findings, [f.finding.message for f in result.findings]


def test_two_releases_differ_and_the_difference_replays(tmp_path):
    # R5 still has `bias` and a 10-number `pid`; R7 has pwmparams, pid_diff, a new help text ...
    args = _args(tmp_path, "--target", "inprocess:R7", "--against", "inprocess:R5", "--budget", "40x",
                 "--seed", "5", "--steps", "8", "--families", "valid", "--shrink-time", "60")
    result, files = from_arguments.run(args, primary=_opener("R7"), secondary=_opener("R5"))
    finding = result.finding("differential")
    assert finding is not None, [f.finding.message for f in result.findings]
    script = load_script(files["differential"]["script"])
    assert len(steps_of(script)) == 2, [a.text for a in script.actions]
    again = replay_script(script, _opener("R7"), get_profile("R7"), fence_s=0.3,
                          against=(_opener("R5"), get_profile("R5")))
    assert again is not None and again.oracle == "differential"
    assert (tmp_path / "differential.against.jsonl").exists()


def test_a_device_dump_on_connecting_is_asynchronous_but_a_listing_is_not():
    dump = (b"P1: connected to active ID 40\r\ntype 40\r\n  M0 COL O SI = PCT\r\n"
            b"P1: established serial communication with active ID 40\r\n")
    assert compare_answers(b"\r\n" + dump + b"P0>", b"\r\nP0>") is None
    # a `list` answer (four headers) just before a connect is still compared
    listed = b"P0: no device detected\r\nP1: connected to active ID 40\r\ntype 40\r\n"
    assert compare_answers(listed + dump, listed) is None
    assert compare_answers(listed + dump, dump) is not None
    listing = b"P0: no device detected\r\nP1: connected to active ID 40\r\ntype 40\r\n"
    shorter = b"P0: no device detected\r\nP1: connected to active ID 40\r\n"
    assert compare_answers(listing, shorter) is not None


def test_a_report_right_after_a_prompt_is_not_compared():
    """A data report can land between a prompt and the next line's echo on either side (its time
    is each target's own): `P3>P3V: ...` then `version` is `P3>version` with a report apart."""
    other = b"\r\nP3>P1V: 0.00000\r\nversion\r\n"
    assert compare_answers(b"\r\nP3>P3V: 0.00000\r\nversion\r\n", other) is None
    assert compare_answers(b"\r\nP3>version\r\n", other) is None
    assert compare_answers(b"\r\nP3>vin\r\n", other) is not None


MATRIX_LISTED = (b"P0: no device detected\r\nP1: connected to active ID 40\r\ntype 40\r\n"
                 b"  M0 LEV O SI = PCT\r\nP2: no device detected\r\nP3: no device detected\r\n")
MATRIX_GONE = (b"P0: no device detected\r\nP1: no device detected\r\n"
               b"P2: no device detected\r\nP3: no device detected\r\n")


def test_a_light_matrix_gone_on_one_side_only_is_a_timing_boundary():
    """The matrix stops talking after its grace without motor power (emulator/devices/matrix.py);
    each side's clock ends that grace at its own instant, so one side may list it and the other not.
    That port's `list` block is then left out; every other difference still counts."""
    diff = first_difference(MATRIX_LISTED, MATRIX_GONE)
    assert diff is not None and parted_matrix(diff[1], diff[2]) == 1
    assert first_difference(MATRIX_LISTED, MATRIX_GONE, frozenset({1})) is None
    # another port's difference is still one
    other = MATRIX_GONE.replace(b"P3: no device detected", b"P3: connected to active ID 30")
    assert first_difference(MATRIX_LISTED, other, frozenset({1})) is not None
    # a motor (ID 30) gone on one side is no timing boundary
    motor = MATRIX_LISTED.replace(b"ID 40\r\ntype 40", b"ID 30\r\ntype 30")
    diff = first_difference(motor, MATRIX_GONE)
    assert diff is not None and parted_matrix(diff[1], diff[2]) is None


def _runner_comparing(a: bytes, b: bytes) -> Runner:
    runner = Runner.__new__(Runner)
    sides = [SimpleNamespace(fence_line=b"Firmware version: x", label=label,
                             link=SimpleNamespace(now=0.0, target_now=0.0, target=SimpleNamespace()))
             for label in ("target", "against")]
    runner.sides, runner.stats, runner._apart = sides, Stats(), set()   # type: ignore[assignment]
    found: list = []
    runner.fail = lambda oracle, message, details: found.append(oracle)    # type: ignore[method-assign]
    runner._differential([b"list\r"], [a, b])
    runner.found = found      # type: ignore[attr-defined]
    return runner


def test_the_runner_stops_comparing_a_parted_matrix_and_says_so():
    runner = _runner_comparing(MATRIX_LISTED, MATRIX_GONE)
    assert runner.found == [] and runner.stats.matrix_apart == 1 and runner._apart == {1}  # type: ignore[attr-defined]
    runner._differential([b"list\r"], [MATRIX_LISTED + b"vin\r\n", MATRIX_GONE])
    assert runner.found == ["differential"]  # type: ignore[attr-defined]


MOTOR_LISTED = (b"P0: connected to active ID 30\r\ntype 30\r\nP1: no device detected\r\n"
                b"P2: no device detected\r\nP3: no device detected\r\n")
MOTOR_GONE = MATRIX_GONE


def test_a_port_one_side_sets_up_again_is_not_compared_until_it_is_established():
    """sil finding (`--seed 11` against inprocess): the firmware dropped the motor after 500 ms
    without data (fb-active) and was setting it up again (about 2 s at 2400 baud) where the emulator,
    whose clock had not paused before the fences as the firmware's did, still listed it."""
    runner = _runner_comparing(MOTOR_LISTED, MOTOR_LISTED)
    assert runner.found == []  # type: ignore[attr-defined]
    target, against = runner.sides
    # the motor's difference alone, before anything happened to it, is a finding
    runner._differential([b"list\r"], [MOTOR_GONE, MOTOR_LISTED])
    assert runner.found == ["differential"]  # type: ignore[attr-defined]
    runner._track(target, b"P0: timeout during data phase: disconnecting\r\nP0: disconnected\r\n")
    runner._differential([b"list\r"], [MOTOR_GONE, MOTOR_LISTED])
    assert runner.found == ["differential"] and runner.stats.reconnect_apart == 1  # type: ignore[attr-defined]
    # another port's difference still counts while port 0 is set up again
    runner._differential([b"list\r"], [MOTOR_GONE, MOTOR_LISTED.replace(b"P3: no device", b"P3: no  device")])
    assert runner.found == ["differential"] * 2  # type: ignore[attr-defined]
    # established again: compared again
    target.link.target_now = 2500.0   # type: ignore[misc]  # a SimpleNamespace standing in for the TargetExchange
    runner._track(target, b"P0: connecting to active device\r\n"
                          b"P0: established serial communication with active ID 30\r\n")
    runner._differential([b"list\r"], [MOTOR_GONE, MOTOR_LISTED])
    assert runner.found == ["differential"] * 3  # type: ignore[attr-defined]


def test_a_set_up_that_ends_in_the_answer_with_the_list_is_left_out_of_that_step():
    """sil finding (`--against emulator --seed 22`, 10 min, one job): the firmware listed port 0 as
    `no device detected` 2.3 s into its set-up, and the same answer went on with the dump and
    `established` (they came before the fence). The answer's events, tracked before the comparison,
    had ended the set-up: a port setting up when the step began is left out of that step too."""
    runner = _runner_comparing(MOTOR_LISTED, MOTOR_LISTED)
    target = runner.sides[0]
    runner._track(target, b"P0: connecting to active device\r\n")     # an earlier step
    at_start = runner._settling()
    assert at_start == {0}
    answer = (MOTOR_GONE + b"set baud rate to 115200\r\nP0: connected to active ID 30\r\ntype 30\r\n"
              b"P0: established serial communication with active ID 30\r\n")
    runner._track(target, answer)
    assert runner._settling() == frozenset()
    runner._differential([b"list\r"], [answer, MOTOR_LISTED])
    assert runner.found == ["differential"]  # type: ignore[attr-defined]
    runner._differential([b"list\r"], [answer, MOTOR_LISTED], settling_at_start=at_start)
    assert runner.found == ["differential"] and runner.stats.reconnect_apart == 1  # type: ignore[attr-defined]


def test_a_report_torn_into_an_echo_is_not_compared():
    """On a wire the report lands between two echoed bytes, at each side's own instant; the
    comparison makes the echo whole (also when the model cannot follow the step: a sil finding)."""
    whole = b"P0>\x0f\xd2abc\xc3def\r\nError\r\nP0>version\r\n"
    torn = b"P0>\x0f\xd2abcP0V: 0.00000\r\n\xc3def\r\nError\r\nP0>version\r\n"
    assert compare_answers(torn, whole) is None
    assert compare_answers(torn, whole.replace(b"def", b"deg")) is not None
    # the stall line of a slow pass, printed while the next line's bytes still arrive (sil: `P0>` and the
    # echo of what came during the pass, `deltat=00000003`, the rest of the echo), and the unpaced
    # emulator's, right after the prompt (both seen with `list` of three active devices then a long line)
    stalled = b"P1>signature ;pw ;pid  3 21474.\xf2deltat=00000003\r\n\xdc\x08 \x08 1\r\nError\r\nP1>"
    at_once = b"P1>deltat=00000003\r\nsignature ;pw ;pid  3 21474.\xf2\xdc\x08 \x08 1\r\nError\r\nP1>"
    assert compare_answers(stalled, at_once) is None
    assert compare_answers(stalled, at_once.replace(b" 1\r\n", b" 2\r\n")) is not None
    for alone in (b"Port power fault", b"Motor power fault", b"MQ overrun!"):
        glued = b"P0>ab" + alone + b"\r\ncd\r\nError\r\nP0>"
        assert compare_answers(glued, b"P0>abcd\r\nError\r\nP0>") is None
    # echoed bytes that look like the start of such a line (`P1: `, `P2V`) before the real cut
    for look in (b"P1: ", b"P2V", b"P3M1", b"deltat"):
        glued = b"P0>x" + look + b"y" + b"deltat=00000003\r\nz\r\nError\r\nP0>"
        assert compare_answers(glued, b"P0>x" + look + b"yz\r\nError\r\nP0>") is None, look
        assert compare_answers(glued, b"P0>x" + look + b"yw\r\nError\r\nP0>") is not None, look
    # a listing line is no report: it is still compared
    assert compare_answers(b"xP0: no device detected\r\nP0>", b"x\r\nP0>") is not None


# The sil finding (`--against emulator --seed 22 --jobs 2`, 10 min; runs 55 and 149 of the seed): the motor's
# set-up ended just after a step's fence answer; the firmware's dump (fb-active: `set baud rate`, the dump,
# `established`) crossed the 115200-baud wire after it, and the read that stopped at the fence answer took
# its first lines. The next answer began with the rest, which without its header read as a `list` answer.
SPLIT_BEFORE = (b"P1>selonc\r\nP1>version\r\nFirmware version: x\r\nP1>set baud rate to 115200\r\n"
                b"P0: connected to active ID 30\r\ntype 30\r\n  nmodes =5\r\n")
SPLIT_REST = (b"  nview  =3\r\n  baud   =115200\r\n  C0: M1+M2+M3\r\n"
              b"P0: established serial communication with active ID 30\r\n"
              b"se  ram -.48\r\nError\r\nP1>version\r\nFirmware version: x\r\nP1>")
UNSPLIT = b"se  ram -.48\r\nError\r\nP1>version\r\nFirmware version: x\r\nP1>"


def test_a_connect_dump_split_by_a_fence_is_put_back_together_for_the_next_comparison():
    after = SPLIT_BEFORE[SPLIT_BEFORE.rfind(b"Firmware version: x") + len(b"Firmware version: x"):]
    leading = open_dump(after)
    assert leading == b"P0: connected to active ID 30\r\ntype 30\r\n  nmodes =5\r\n"
    runner = _runner_comparing(UNSPLIT, UNSPLIT)
    runner._differential([b"se  ram -.48\r"], [SPLIT_REST, UNSPLIT])       # the rest alone: a `list` answer
    assert runner.found == ["differential"]  # type: ignore[attr-defined]
    runner._differential([b"se  ram -.48\r"], [SPLIT_REST, UNSPLIT], (leading, b""))
    assert runner.found == ["differential"]  # type: ignore[attr-defined]
    # a real difference after the dump still counts
    other = UNSPLIT.replace(b"Error\r\n", b"")
    runner._differential([b"se  ram -.48\r"], [SPLIT_REST, other], (leading, b""))
    assert runner.found == ["differential"] * 2  # type: ignore[attr-defined]


def test_only_a_dump_still_open_is_carried():
    # ended (its `established` came), a passive device (no dump), nothing after the fence
    assert open_dump(b"P0: connected to active ID 30\r\ntype 30\r\n"
                     b"P0: established serial communication with active ID 30\r\n") == b""
    assert open_dump(b"P1>P2: connected to passive ID 8\r\n") == b""
    assert open_dump(b"P1>") == b""
    # a prompt before the header goes; a line still arriving is the link's (it begins the next answer)
    assert open_dump(b"P1>P0: connected to active ID 30\r\ntype 30\r\n  nmo") == (
        b"P0: connected to active ID 30\r\ntype 30\r\n")
    # what a wait then reads ends it
    assert open_dump(open_dump(SPLIT_BEFORE) + SPLIT_REST) == b""

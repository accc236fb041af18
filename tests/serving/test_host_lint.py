"""The host-traffic lint (serving/host_lint/lint.py) on the in-process emulator, in virtual time.

Each wrong host here makes a mistake FIRMWARE-FACTS documents (§1 CRLF, §11 `bias`/`pid` per release,
§1 early input); the expectations come from those facts, not from the lint's code.
"""
from __future__ import annotations

from typing import Dict, List

import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.serving.host_lint.intake import IntakeModel
from buildhat_conformance.serving.host_lint.lint import HostLint

EMPTY = {0: "none", 1: "none", 2: "none", 3: "none"}


def booted(firmware: str) -> tuple[Emulator, HostLint]:
    emu = Emulator(firmware=firmware, devices=EMPTY)
    emu.boot()
    return emu, HostLint.for_hat(emu.hat)


def send(emu: Emulator, lines: List[bytes], gap_ms: int = 5) -> bytes:
    for line in lines:
        emu.write(line)
        emu.advance(gap_ms)
    return emu.read()


def nonzero(lint: HostLint) -> Dict[str, int]:
    lint.finish()
    return {k: v for k, v in lint.summary()["counts"].items() if v}


def test_wrong_host_on_r7_is_caught_line_by_line() -> None:
    emu, lint = booted("1737564117")
    out = send(emu, [b"version\r\n", b"vin\r",                         # CRLF: the LF starts `\nvin`
                     b"port 0 ; plimit 1 ; bias .4\r",                   # bias is R1-R5 only
                     b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3\r"])         # the 2021 document's 10 numbers
    assert out.count(b"Error\r\n") == 3                                  # the HAT's own view of it
    assert nonzero(lint) == {"error": 3, "crlf": 1, "not_in_profile": 1, "pid_arity": 1}
    by_kind = {f["kind"]: f for f in lint.summary()["findings"] if f["kind"] != "error"}
    assert by_kind["crlf"]["line"] == 2 and by_kind["crlf"]["text"] == "\\nvin"
    assert "'bias'" in by_kind["not_in_profile"]["detail"] and by_kind["not_in_profile"]["line"] == 3
    assert "10 numbers" in by_kind["pid_arity"]["detail"] and "takes 11" in by_kind["pid_arity"]["detail"]
    message = lint.fatal_message()
    assert message is not None and "line 2" in message and "\\\\nvin" in message and "crlf" in message


def test_python_library_090_sequence_is_clean_on_r7() -> None:
    # What buildhat 0.9.0 sends for Motor('A') + run_for_degrees (read from its source), on its own release.
    emu, lint = booted("1737564117")
    send(emu, [b"port 0 ; select ; port 1 ; select ; port 2 ; select ; port 3 ; select ; echo 0\r",
               b"list\r", b"port 0 ; port_plimit 0.7\r", b"port 0 ; pwmparams 0.65 0.01\r",
               b"port 0; select 0 ; selrate 10; pid 0 0 1 s4 0.0027777778 0 5 0 .1 3 0.01; "
               b"set ramp 0.0 0.25 0.1 0\r", b"port 0 ; coast\r"])
    assert nonzero(lint) == {}
    assert lint.summary()["clean"] and lint.fatal_message() is None


def test_release_r2_takes_bias_and_ten_numbers_but_not_the_r6_words() -> None:
    emu, lint = booted("1636109636")
    send(emu, [b"port 0 ; plimit 0.7\r", b"port 0 ; bias 0.3\r",
               b"pid 0 0 1 s4 0.0027777778 0 5 0 .1 3\r"])
    assert nonzero(lint) == {}, lint.report()
    send(emu, [b"port 0 ; selrate 10\r",                                  # R5+
               b"pid 0 0 1 s4 0.0027777778 0 5 0 .1 3 0.01\r",            # 11 numbers: applied, then Error
               b"# a comment\r"])                                        # R6+
    counts = nonzero(lint)
    assert counts == {"error": 3, "not_in_profile": 2, "pid_arity": 1}, lint.report()


def test_input_sent_during_start_up_is_flagged() -> None:
    emu = Emulator(firmware="1737564117", devices=EMPTY)
    lint = HostLint.for_hat(emu.hat)
    emu.advance(50)                       # past the input-discard window, inside port initialisation
    emu.write(b"vin\r")
    emu.boot()
    emu.advance(20)                       # the main loop takes the buffered line after start-up
    assert nonzero(lint) == {"before_ready": 1}, lint.report()


# What python-build-hat 0.9.0 sends for Motor.start() (its motor line) and a short one; its upstream stress
# tests (test_continuous_start / _degrees) run such lines at about 768 and 112 lines/s against a real HAT.
MOTOR_LINE = (b"port 0; select 0 ; selrate 10; pid 0 0 1 s4 0.0027777778 0 5 0 .1 3 0.01; "
              b"set ramp 0.0 0.25 0.1 0\r")


def send_at_rate(emu: Emulator, line: bytes, per_second: int, seconds: int) -> None:
    start = emu.now
    for i in range(per_second * seconds):
        due = start + (i * 1000) // per_second
        if due > emu.now:
            emu.advance(due - emu.now)
        emu.write(line)
    emu.advance(50)
    emu.read()


@pytest.mark.parametrize("per_second", [112, 768])
@pytest.mark.parametrize("line", [MOTOR_LINE, b"port 0 ; set 0\r"], ids=["motor_line", "short_line"])
def test_the_official_librarys_stress_rates_are_no_finding(per_second: int, line: bytes) -> None:
    # FIRMWARE-FACTS §1: the wire carries 11.52 bytes/ms into an 8192-byte ring and a short line costs the
    # main loop far less than its bytes take to arrive, so no rate of such lines loses input on a HAT.
    emu, lint = booted("1737564117")
    send_at_rate(emu, line, per_second, 3)
    assert lint.lines == per_second * 3
    assert nonzero(lint) == {}, lint.report()


def test_a_list_storm_overruns_the_receive_ring_and_lint_says_so_while_it_lasts() -> None:
    # Three active motors: each `list` costs the main loop milliseconds (§5's stall line) but takes 0.43 ms
    # on the wire, so back-to-back lists pile up in the ring until it would drop input.
    emu = Emulator(firmware="1737564117", devices={0: "0x30", 1: "0x30", 2: "0x30", 3: "none"})
    emu.boot()
    lint = HostLint.for_hat(emu.hat)
    for _ in range(20):
        emu.write(b"list\r" * 100)
        emu.advance(1)
        emu.read()
    live = lint.summary()                     # the episode is still open: counted and shown alike
    assert live["counts"]["overrun"] == 1 and not live["clean"]
    (finding,) = [f for f in live["findings"] if f["kind"] == "overrun"]
    assert "8192-byte receive ring" in finding["detail"]
    assert "overrun" in (lint.fatal_message() or "")            # --strict-host stops at once, not at its end
    assert nonzero(lint) == {"overrun": 1}, lint.report()     # closing it reports the same one finding


def test_intake_model_holds_what_the_hat_has_not_run_yet() -> None:
    # Derived by hand from the wire rate: 100 bytes take 100 / 11.52 = 8.7 ms to arrive.
    model = IntakeModel(ring=1000)
    assert model.line(0, 100, 0.01) == 100          # run long before the next one arrives
    assert model.line(0, 100, 0.01) == 100
    slow = IntakeModel(ring=1000)
    held = [slow.line(0, 10, 50.0) for _ in range(5)]   # each costs 50 ms, arrives in under 1 ms
    assert held == [10, 20, 30, 40, 50]


def test_lf_only_line_endings_leave_unterminated_input() -> None:
    emu, lint = booted("1737564117")
    send(emu, [b"vin\n"])
    assert nonzero(lint) == {"unterminated": 1}
    assert "'vin\\\\n'" in lint.report()      # the LF shown escaped


def test_without_a_hat_the_raw_input_shows_unterminated_bytes_once() -> None:
    lint = HostLint(profile_of=lambda: None)   # e.g. a session that never left the bootloader
    lint.feed_input(b"version\rvin\n")
    lint.finish()
    lint.finish()                                  # the exit path may call it twice
    assert lint.counts["unterminated"] == 1 and "'vin\\\\n'" in lint.report()


def test_a_pid_behind_an_earlier_failure_is_reported_as_not_reached() -> None:
    # buildhat 0.9.0's motor line on R2: `selrate` fails first, so the 11-number pid never runs.
    emu, lint = booted("1636109636")
    send(emu, [b"port 0; select 0 ; selrate 10; pid 0 0 1 s4 0.0027777778 0 5 0 .1 3 0.01; "
               b"set ramp 0.0 0.25 0.2 0\r"])
    assert nonzero(lint) == {"error": 1, "not_in_profile": 1, "pid_arity": 1}, lint.report()
    (arity,) = [f for f in lint.summary()["findings"] if f["kind"] == "pid_arity"]
    assert "11 numbers" in arity["detail"] and "not reached" in arity["detail"]


def test_replies_that_overflow_the_transmit_ring_on_a_paced_wire_are_an_overrun() -> None:
    # FIRMWARE-FACTS §1: output that does not fit the 8192-byte TX ring is dropped. Three `list` dumps of
    # three motors (kilobytes each) asked back to back on a 115200-baud wire cannot all fit.
    emu = Emulator(firmware="1737564117", devices={0: "0x30", 1: "0x30", 2: "0x30", 3: "none"}, baud=115200)
    emu.boot()
    emu.advance(2000)                     # the start-up's output has left the ring
    emu.read()
    lint = HostLint.for_hat(emu.hat)
    emu.write(b"list\rlist\rlist\rlist\rvin\r")
    emu.advance(50)
    assert emu.uart.tx_dropped > 0                          # the emulator's ring model did drop output
    (finding,) = [f for f in lint.summary()["findings"] if f["kind"] == "overrun"]
    assert "transmit ring" in finding["detail"] and "dropped" in finding["detail"]


def test_the_intake_costs_lines_with_the_profiles_own_cost_model() -> None:
    """One source of truth: the lint's line cost is the profile's ``main_loop_cost`` data (the default
    release's when no profile is known), and a `list` costs what the HAT's active devices print."""
    import dataclasses

    from buildhat_conformance.protocol.profiles import get_profile
    from buildhat_conformance.serving.host_lint.intake import line_cost_ms

    r7 = get_profile("R7")
    base = r7.features["main_loop_cost"]
    assert line_cost_ms(r7, b"vin", ["vin"], None) == pytest.approx(
        (base["line_us"] + 3 * base["text_byte_us"]) / 1000)
    assert line_cost_ms(None, b"vin", ["vin"], None) == line_cost_ms(get_profile(), b"vin", ["vin"], None)
    slower = dataclasses.replace(r7, features={**r7.features,
                                               "main_loop_cost": {k: 2 * v for k, v in base.items()
                                                                  if not k.startswith("_")}})
    vin = line_cost_ms(r7, b"vin", ["vin"], None)
    assert line_cost_ms(slower, b"vin", ["vin"], None) == pytest.approx(2 * vin)
    idle, _ = booted("1737564117")
    busy = Emulator(firmware="1737564117", devices={0: "0x30", 1: "0x3E", 2: "0x3D", 3: "none"})
    busy.boot()
    # §5: the list of a motor, a distance and a colour sensor stretches the pass past 2 ms (deltat=00000003).
    assert line_cost_ms(r7, b"list", ["list"], busy.hat) > 2.0 > line_cost_ms(r7, b"list", ["list"], idle.hat)

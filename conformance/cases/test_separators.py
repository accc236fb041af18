"""SYN-SEMICOLON: several commands on one line, separated by semicolons.

docs/FIRMWARE-BEHAVIOUR.md#fb-matching, #fb-separators, #fb-errors: runs of spaces and `;`
between commands are skipped; a `;` may follow a name directly (`set;0.25`); a separator is not
even needed (`port 1 vin`); an error prints `Error`, keeps everything done before it on the line
and drops the rest.
"""
from __future__ import annotations

import pytest

from ..hat_under_test import HatUnderTest
from ..mismatch import accepted, rejected, same
from ..probes import pid_lines, reports_after, start_quiet_pid
from .test_link import vin_line


@pytest.mark.req("SYN-SEMICOLON")
@pytest.mark.parametrize("line", ["vin ; vin", "vin;vin", "vin ;;; vin", ";vin;vin;", "  vin  ;  vin  ",
                                  "vin; ;vin", ";;vin ; ; ; vin;;"])
def test_two_commands_on_one_line_both_run(hat: HatUnderTest, line: str) -> None:
    answer = vin_line(hat)
    same(hat.exchange_quiet(line), b"\r\n" + answer + answer)


@pytest.mark.req("SYN-SEMICOLON", "FW-SEPARATOR-OPTIONAL")
def test_no_separator_is_needed_between_commands(hat: HatUnderTest) -> None:
    answer = vin_line(hat)
    same(hat.exchange_quiet("vin vin"), b"\r\n" + answer + answer)
    hat.exchange("echo 1")
    raw = hat.exchange("port 1 vin").raw
    hat.exchange("echo 0 ; port 0")
    same(raw, b"port 1 vin\r\n" + answer + b"P1>", sent="port 1 vin")


@pytest.mark.req("SYN-SEMICOLON")
@pytest.mark.parametrize("line", [";", ";;;", " ; ; ; ", "   "])
def test_empty_commands_do_nothing(hat: HatUnderTest, line: str) -> None:
    same(hat.exchange(line), b"\r\n")


@pytest.mark.req("SYN-SEMICOLON", "FW-SEMICOLON-AFTER-NAME")
def test_semicolon_right_after_a_name_ends_the_name(hat: HatUnderTest, motor_port: int) -> None:
    hat.exchange("echo 1")
    raw = hat.exchange("port;2").raw
    hat.exchange("echo 0 ; port 0")
    assert raw == b"port;2\r\nP2>", "`port;2` is `port 2` (docs/FIRMWARE-BEHAVIOUR.md#fb-matching)"
    start_quiet_pid(hat, motor_port)
    reply = hat.exchange("set;0.25")
    lines = pid_lines(reports_after(hat, motor_port), motor_port)
    accepted(reply)
    assert lines and {ln.sp for ln in lines} == {"0.250000"}, \
        f"sent `set;0.25`: expected the PID's set-point 0.250000, came {sorted({ln.sp for ln in lines})}"


@pytest.mark.req("SYN-SEMICOLON", "FW-ERROR")
def test_error_mid_line_keeps_earlier_effects_and_drops_the_rest(hat: HatUnderTest) -> None:
    answer = vin_line(hat)
    same(hat.exchange_quiet("vin ; bogus ; vin"), b"\r\n" + answer + b"Error\r\n")
    hat.exchange("echo 1")
    raw = hat.exchange("port 1 ; bogus ; port 2").raw
    hat.exchange("echo 0 ; port 0")
    assert raw == b"port 1 ; bogus ; port 2\r\nError\r\nP1>", "port 1 stays, port 2 never runs"


@pytest.mark.req("SYN-SEMICOLON", "FW-ERROR")
def test_bad_argument_mid_line_drops_the_rest(hat: HatUnderTest) -> None:
    answer = vin_line(hat)
    same(hat.exchange_quiet("vin ; ledmode x ; vin"), b"\r\n" + answer + b"Error\r\n")
    assert hat.exchange("ledmode 1 2 ; vin").raw == b"\r\nError\r\n", "`2` is not a command"
    hat.exchange("ledmode -1")


@pytest.mark.req("SYN-SEMICOLON", "FW-ARGUMENTS-END")
def test_arguments_end_at_a_semicolon(hat: HatUnderTest, motor_port: int) -> None:
    # docs/FIRMWARE-BEHAVIOUR.md#fb-separators: number parsers skip spaces only, so `;` ends the
    # argument list: `0.3` is then read as a command (Error), after `set 0.5` has taken effect.
    start_quiet_pid(hat, motor_port)
    reply = hat.exchange("set 0.5;0.3")
    lines = pid_lines(reports_after(hat, motor_port), motor_port)
    rejected(reply)
    assert lines and {ln.sp for ln in lines} == {"0.500000"}, \
        f"sent `set 0.5;0.3`: expected the PID's set-point 0.500000, came {sorted({ln.sp for ln in lines})}"


@pytest.mark.req("SYN-SEMICOLON", "FW-LINE-CR-CRLF")
def test_several_lines_in_one_write(hat: HatUnderTest) -> None:
    answer = vin_line(hat)
    same(hat.exchange_quiet(b"vin\rvin ; vin\r"), b"\r\n" + answer + b"\r\n" + answer + answer)


@pytest.mark.req("SYN-SEMICOLON", "FW-ERROR")
def test_list_followed_by_a_number_is_list_then_error(hat: HatUnderTest) -> None:
    reply = hat.exchange_quiet("list 0")
    lines = reply.list_lines()
    assert reply.lines[-1] == "Error" and len(lines) >= 4, \
        f"sent `list 0`: expected the list of 4 ports, then `Error`; came {reply.lines[-3:]}"


@pytest.mark.req("SYN-SEMICOLON", "FW-ERROR")
def test_error_mid_line_keeps_an_earlier_setting(hat: HatUnderTest, motor_port: int) -> None:
    start_quiet_pid(hat, motor_port)
    reply = hat.exchange("set 0.3 ; bogus ; set 0.9")
    lines = pid_lines(reports_after(hat, motor_port), motor_port)
    rejected(reply)
    assert lines and {ln.sp for ln in lines} == {"0.300000"}, "set 0.3 stays; set 0.9 never runs"

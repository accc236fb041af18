"""Issue 24: a wrong but well-formed answer is a ``fail`` of the clause it breaks, never a target
fault; the harness checks the clauses its own set-up relies on first; skips settle once and say
exactly what is missing; a run that could not do its job exits 3 in one line. Issue 25: a Build HAT
that answers `version` without its version line (but with the CRLF and lines only a Build HAT
prints) fails the version clause; a device that is not a Build HAT is still refused, exit 3.

The HATs are real programs (tests/faulty/wrong_hat.py: ``buildhat-emulator --stdio`` with one
behaviour changed) run as ``cmd:`` targets through the user's ``buildhat-conformance run``.
"""
from __future__ import annotations

import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from typing import Dict, Tuple

import pytest
from faulty.wrong_hat import PortlessPrompt, first_command, no_echo, port_error, version_error
from junit_props import properties
from mutants.suite_run import REPO

pytestmark = pytest.mark.timeout(300)

WRONG_HAT = os.path.join(REPO, "tests", "faulty", "wrong_hat.py")
EMULATOR = os.path.join(os.path.dirname(sys.executable), "buildhat-emulator")
NOT_A_HAT = os.path.join(REPO, "tests", "faulty", "not_a_hat.py")


Cases = Dict[str, Tuple[str, str, Dict[str, str]]]


def _run(tmp, target: str, *args: str) -> Tuple[int, str, Cases]:
    """``buildhat-conformance run``: (exit status, output, case -> (verdict, message, properties))."""
    junit = os.path.join(str(tmp), "r", "junit.xml")
    argv = [sys.executable, "-m", "buildhat_conformance", "run", "-t", target, "--junit", junit, *args]
    proc = subprocess.run(argv, cwd=str(tmp), capture_output=True, text=True, timeout=280,
                          env=dict(os.environ, PYTHONWARNINGS="ignore"))
    cases: Cases = {}
    if os.path.isfile(junit):
        for case in ET.parse(junit).getroot().iter("testcase"):
            props = properties(case)
            problem = next((c for c in case if c.tag in ("failure", "error", "skipped")), None)
            message = "" if problem is None else problem.get("message", "")
            cases[case.get("name") or ""] = (props.get("verdict", ""), message, props)
    return proc.returncode, proc.stdout + proc.stderr, cases


def _wrong(kind: str) -> str:
    return f"cmd:{sys.executable} {WRONG_HAT} {kind} -- --booted --speed 20"


def test_the_wrappers_change_only_their_behaviour() -> None:
    assert port_error(b"port 9") == b"port x" and port_error(b"port 12 ; vin") == b"port xx ; vin"
    assert port_error(b"port 3") == b"port 3" and port_error(b"p 4") == b"p x"
    assert first_command(b"vin ; vin") == b"vin \x00 vin"
    assert first_command(b";;vin;vin") == b";;vin\x00vin" and first_command(b"vin") == b"vin"
    assert no_echo(b"echo 1 ; vin") == b"echo 0 ; vin" and no_echo(b"e 15") == b"e 00"
    prompt = PortlessPrompt()
    assert prompt.output(b"\r\nP0>vin\r\nP3M1: 5\r\nP") == b"\r\nP>vin\r\nP3M1: 5\r\n"
    assert prompt.output(b"2>") == b"P>" and prompt.output(b"P1: ok") + prompt.flush() == b"P1: ok"


def test_port_9_answered_with_error_fails_the_clamping_clause(tmp_path) -> None:
    rc, out, cases = _run(tmp_path, _wrong("port-error"), "-k", "clause or port_above or port_sets")
    verdicts = {name: v for name, (v, _m, _p) in cases.items()}
    assert rc == 1, out[-3000:]
    assert verdicts["test_port_above_3_is_clamped_to_3[port 9]"] == "fail", verdicts
    assert "port clamping" in cases["test_port_above_3_is_clamped_to_3[port 9]"][1]
    assert "target-fault" not in verdicts.values() and "not-run" not in verdicts.values(), verdicts
    assert verdicts["test_port_sets_the_current_port[port 2-2-False]"] == "pass", verdicts


def test_a_hat_that_runs_only_the_first_command_fails_the_separator_clause(tmp_path) -> None:
    rc, out, cases = _run(tmp_path, _wrong("first-command"), "-k",
                          "clause or test_vin_prints or test_port_sets or test_four_ports or two_commands")
    verdicts = {name: v for name, (v, _m, _p) in cases.items()}
    assert rc == 1, out[-3000:]
    assert verdicts["test_clause_semicolon_separates_commands"] == "fail", verdicts
    assert "target-fault" not in verdicts.values() and "not-run" not in verdicts.values(), verdicts
    # The rest of the run still reports verdicts: cases without `;` pass, those with it fail.
    for name in ("test_clause_cr_ends_a_line_with_crlf",
                 "test_clause_echo_on_echoes_and_prompts_echo_off_stops",
                 "test_vin_prints_volts_with_two_decimals", "test_four_ports_numbered_0_to_3",
                 "test_port_sets_the_current_port[port 1-1-False]"):
        assert verdicts[name] == "pass", (name, verdicts)
    assert verdicts["test_two_commands_on_one_line_both_run[vin ; vin]"] == "fail", verdicts
    assert "SYN-SEMICOLON" in out and "broke" in out, out[-2000:]
    junit = open(os.path.join(tmp_path, "r", "junit.xml"), encoding="utf-8").read()
    assert 'name="broken_clauses" value="SYN-SEMICOLON' in junit


def test_a_hat_whose_echo_never_turns_on_fails_the_echo_clause_only(tmp_path) -> None:
    # The sync between cases needs echo: without it the set-up fences by counting, and the run
    # goes on giving verdicts.
    keyword = "clause or test_vin_prints or test_four_ports or two_commands or test_list"
    rc, out, cases = _run(tmp_path, _wrong("no-echo"), "-k", keyword)
    verdicts = {name: v for name, (v, _m, _p) in cases.items()}
    assert rc == 1, out[-3000:]
    assert [n for n, v in verdicts.items() if v == "fail"] == \
        ["test_clause_echo_on_echoes_and_prompts_echo_off_stops"], verdicts
    assert "target-fault" not in verdicts.values() and len(verdicts) > 10, verdicts
    assert "CMD-ECHO" in out, out[-2000:]


def test_a_hat_whose_prompt_lacks_its_port_fails_the_echo_clause(tmp_path) -> None:
    # `P>` for `P0>` hides the fence's echo from the link; the HAT still answers it whole, so it
    # is a failing clause (LINK-PROMPT), not a garbled link.
    rc, out, cases = _run(tmp_path, _wrong("portless-prompt"), "-k", "clause or test_vin_prints")
    verdicts = {name: v for name, (v, _m, _p) in cases.items()}
    assert rc == 1, out[-3000:]
    assert verdicts["test_clause_echo_on_echoes_and_prompts_echo_off_stops"] == "fail", verdicts
    assert "P>" in cases["test_clause_echo_on_echoes_and_prompts_echo_off_stops"][1], cases
    assert verdicts["test_vin_prints_volts_with_two_decimals"] == "pass", verdicts


def test_skips_settle_once_and_name_the_second_motor(tmp_path) -> None:
    # No control channel: nothing can be plugged. The layout has one motor, so the cases that need
    # a second one say exactly that; the wait for devices to settle happens once in the run.
    target = f"cmd:{EMULATOR} --stdio --booted --speed 20 --device 0=0x30 --device 1=none --device 2=none " \
             "--device 3=none"
    rc, out, cases = _run(tmp_path, target, "-k", "each_port_has_its_own or port_plimit_limits_one")
    skipped = {name: (m, p) for name, (v, m, p) in cases.items() if v == "skip"}
    second = [m for m, _p in skipped.values() if "second" in m]
    assert second and all(m.startswith("needs a second SPIKE Prime Medium Angular Motor") and "port 0" in m
                          for m in second), skipped
    from buildhat_conformance.conformance.needs import SETTLE_MS

    settled = [name for name, (_m, p) in skipped.items() if float(p.get("hat_wait_ms", "0")) >= SETTLE_MS]
    assert len(settled) <= 1, f"waited for devices in more than one case: {settled}"
    assert "cases skipped: no control channel" in out, out[-1500:]


def test_a_run_where_every_case_skips_exits_3_in_one_line(tmp_path) -> None:
    target = f"cmd:{EMULATOR} --stdio --booted --speed 20"
    rc, out, cases = _run(tmp_path, target, "-k", "test_vin_follows_the_supply")
    assert cases and all(v == "skip" for v, _m, _p in cases.values()), cases
    assert rc == 3, out[-1500:]
    assert "NOTHING RAN" in out and "the run could not do its job: no case could run" in out, out[-1500:]


def test_judging_a_known_release_as_another_exits_3_in_one_line(tmp_path) -> None:
    rc, out, cases = _run(tmp_path, "inprocess:R7", "--firmware", "R2", "-k", "test_version")
    assert rc == 3 and not cases, out
    lines = [ln for ln in out.splitlines() if ln.strip()]
    assert len(lines) == 1 and "runs R7" in lines[0], out
    assert "not R2 that --firmware judges it by" in lines[0], out


def test_a_clause_is_trusted_only_after_its_case_passed_and_never_after_it_failed() -> None:
    from buildhat_conformance.conformance.trusted_clauses import TrustedClauses

    clauses = TrustedClauses()
    assert not clauses.trusted("separator") and clauses.split("port 1 ; select") == ["port 1", "select"]
    clauses.held("separator")
    assert clauses.trusted("separator") and clauses.split("port 1 ; select") == ["port 1 ; select"]
    clauses.broke("echo", "conformance/cases/test_link_clauses.py::test_clause_echo")
    clauses.held("echo")
    assert not clauses.trusted("echo")
    assert clauses.broken() == ["CMD-ECHO (`echo 1` echoes what is typed and prompts, `echo 0` stops it) "
                                "failed in test_link_clauses.py::test_clause_echo"]


def test_the_banner_says_how_much_was_skipped_and_why() -> None:
    from buildhat_conformance.conformance.plugin.run_outcome import banner, nothing_done

    results = {f"c{i}": ("skip" if i < 3 else "pass", []) for i in range(10)}
    reasons = {f"c{i}": "needs a second motor: connect another" for i in range(3)}
    assert banner(results, reasons, False) == "CONFORMS (3 of 10 cases skipped: no control channel)"
    assert banner(results, reasons, True) == "CONFORMS (3 of 10 cases skipped: needs a second motor)"
    assert nothing_done(results, reasons, False) is None
    results["c5"] = ("fail", [])
    assert banner(results, reasons, False).startswith("FAILS: 1 finding(s)")
    skipped = {f"c{i}": ("skip", []) for i in range(2)}
    assert nothing_done(skipped, {"c0": "needs x", "c1": "needs y"}, False) == \
        "no case could run (2 of 2 cases skipped: no control channel)"



def test_the_wrapper_changes_only_version() -> None:
    assert version_error(b"version") == b"xersion" and version_error(b"vin ; ve") == b"vin ; xe"
    assert version_error(b"vin") == b"vin" and version_error(b"v") == b"v"


def test_a_hat_answering_version_with_error_fails_the_version_clause(tmp_path) -> None:
    rc, out, cases = _run(tmp_path, _wrong("version-error"), "-k", "clause or test_vin_prints")
    verdicts = {name: v for name, (v, _m, _p) in cases.items()}
    assert rc == 1, out[-3000:]
    assert verdicts.pop("test_clause_version_answers_one_line") == "fail", verdicts
    assert "CMD-VERSION" in cases["test_clause_version_answers_one_line"][1]
    assert verdicts and set(verdicts.values()) == {"not-run"}, verdicts
    assert "answers like a Build HAT but breaks the version clause" in out, out[-3000:]


def test_a_device_that_is_not_a_build_hat_is_refused_in_one_line(tmp_path) -> None:
    rc, out, cases = _run(tmp_path, f"cmd:{sys.executable} {NOT_A_HAT}", "-k", "clause")
    assert rc == 3 and not cases, out
    lines = [ln for ln in out.splitlines() if ln.strip()]
    assert len(lines) == 1 and "not like a Build HAT" in lines[0], out

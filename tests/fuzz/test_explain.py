"""A finding says what went wrong (issue 24): its terminal line and its script's header name the
step sent, the line whose answer went wrong, and the first line that differs: expected vs got, or
for a differential finding, what each target printed."""
from __future__ import annotations

import argparse
import pathlib
from typing import Dict, Optional

from planted.faults import FAULTS

from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.fuzz import cli
from buildhat_conformance.fuzz.oracles.registry import Finding
from buildhat_conformance.fuzz.running import from_arguments
from buildhat_conformance.fuzz.running.checked_run import Runner
from buildhat_conformance.protocol.profiles import get_profile

EMPTY: Dict[int, Optional[tuple]] = {0: None, 1: None, 2: None, 3: None}


def test_a_finding_line_and_its_script_name_the_step_and_the_differing_lines(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    args = parser.parse_args(["--target", "inprocess:R7", "--budget", "20x", "--seed", "4", "--steps", "6",
                              "--families", "valid", "--confirm", "1", "--shrink-time", "20", "--waits", "",
                              "--out", str(tmp_path), "--quiet", "--no-database"])
    args.devices = EMPTY
    # the planted fault: `coast` also prints Error
    result, files = from_arguments.run(args, primary=lambda: InProcessTarget("R7", devices=EMPTY,
                                                                      factory=FAULTS["wrong"]))
    finding = result.finding("fate")
    assert finding is not None, [f.finding.message for f in result.findings]
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("  FINDING [fate]"))
    # the line sent (a `coast` abbreviation) in its step, and expected vs got
    assert "line b'co" in line and " of step b'" in line, line
    assert "first differing line: expected " in line and ", got b'Error'" in line, line
    header = pathlib.Path(files["fate"]["script"]).read_text(encoding="utf-8")
    assert ";; step sent: b'" in header and ";; line: b'co" in header, header
    assert ";; expected line: " in header and ";; got line: b'Error'" in header, header


def test_a_differential_finding_names_the_step_and_what_each_target_printed():
    r7, r5 = get_profile("R7"), get_profile("R5")
    runner = Runner([("target", lambda: InProcessTarget("R7", devices=EMPTY), r7),
                     ("against", lambda: InProcessTarget("R5", devices=EMPTY), r5)], 0.3, True, devices=EMPTY)
    try:
        runner.start()
        runner.exchange([b"pwmparams 0 0\r"])            # R7 takes it; R5 does not know it
        raise AssertionError("no differential finding")
    except Finding as finding:
        assert finding.oracle == "differential", finding.message
        msg = finding.message
        assert msg.startswith("step b'pwmparams 0 0\\rversion\\r': first differing line"), msg
        assert "target printed " in msg and "against printed b'Error\\r\\n'" in msg, msg
        assert finding.details["against_line"] == b"Error\r\n"
    finally:
        runner.close()


def test_a_step_is_cut_after_every_cr_as_the_hat_processes_it():
    from buildhat_conformance.fuzz.findings.explain import sent_lines, shown

    assert sent_lines(b"vin\rport 0 ; list\r\rver") == [b"vin\r", b"port 0 ; list\r", b"\r", b"ver"]
    assert sent_lines(b"") == []
    assert shown(None) == "nothing"
    assert shown(b"x" * 200, limit=10) == repr(b"x" * 10) + "... (200 bytes)"

"""`buildhat-conformance fuzz` as a user runs it: budget units, seeds, reproducing a finding, the
progress line, and campaigns on real-time paced targets (which must run their whole budget).

The command runs as a real subprocess; the targets are the real emulator (in-process, or its own
process behind a pty) and a planted fault as a `cmd:` byte proxy (tests/planted/proxy.py)."""
from __future__ import annotations

import io
import os
import pathlib
import re
import shlex
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from junit_props import properties
from repo_paths import TESTS

from buildhat_conformance.fuzz.running.campaign import Budget, parse_budget
from buildhat_conformance.fuzz.running.checked_run import PRELUDE, Stats
from buildhat_conformance.fuzz.summary import Progress

HERE = TESTS
EXE = os.path.join(os.path.dirname(sys.executable), "buildhat-conformance")
SUMMARY = re.compile(r"^fuzz: (\d+) runs, (\d+) inputs \((\d+) lines, (\d+) lines/s\) in ([\d.]+) s", re.M)


def _fuzz(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([EXE, "fuzz", *args], capture_output=True, text=True, timeout=timeout)


def test_budget_takes_explicit_units_and_refuses_a_bare_number():
    assert parse_budget("60s") == Budget(seconds=60)
    assert parse_budget("2m") == Budget(seconds=120)
    assert parse_budget("500x") == Budget(examples=500)
    with pytest.raises(ValueError, match=r"say 30s for seconds or 30x for runs"):
        parse_budget("30")
    with pytest.raises(ValueError):
        parse_budget("0s")


def test_a_bare_budget_is_a_usage_error_with_a_hint(tmp_path):
    res = _fuzz("--budget", "30", "--out", str(tmp_path))
    assert res.returncode == 2
    assert "30s" in res.stderr and "30x" in res.stderr and "Traceback" not in res.stderr


def test_an_unseeded_run_prints_and_stores_its_seed_and_the_seed_repeats_it(tmp_path):
    res = _fuzz("--budget", "2x", "--steps", "5", "--out", str(tmp_path / "a"), "--no-database")
    assert res.returncode == 0, res.stdout + res.stderr
    seed = re.search(r"seed: (\d+) \(chosen at random; --seed \1 repeats this campaign\)", res.stdout)
    assert seed is not None, res.stdout
    props = properties(ET.parse(tmp_path / "a" / "junit.xml").getroot())
    assert props["seed"] == seed.group(1)
    again = _fuzz("--budget", "2x", "--steps", "5", "--out", str(tmp_path / "b"), "--no-database",
                  "--seed", seed.group(1))
    first, second = SUMMARY.search(res.stdout), SUMMARY.search(again.stdout)
    assert first and second and first.group(2, 3) == second.group(2, 3)   # the same inputs


def _proxy_url(fault: str) -> str:
    return (f"cmd:{sys.executable} {HERE / 'planted' / 'proxy.py'} {fault} "
            "--device 0=none --device 1=none --device 2=none --device 3=none")


def _coast_script(path: pathlib.Path) -> pathlib.Path:
    lines = [f"> {line.decode()}" for line in PRELUDE.split(b"\r") if line]
    path.write_text("\n".join(lines + ["> version", "> co", "> version"]) + "\n", encoding="utf-8")
    return path


def test_not_reproduced_on_a_fresh_target_recalls_a_finding_that_began_on_a_kept_open_one(tmp_path):
    script = _coast_script(tmp_path / "coast.script")
    text = script.read_text(encoding="utf-8")
    script.write_text(";; began on: a target earlier runs had left open; a freshly started one may not "
                      "reproduce it\n" + text, encoding="utf-8")
    res = _fuzz("--reproduce", str(script), "--target", "inprocess:R7", "--confirm", "1")
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stdout.startswith("not reproduced (0/1 replays)")
    assert "the finding began on a target earlier runs had left open" in res.stdout, res.stdout


# A `list` as the first step after the prelude: both sides were opened just before it.
_FIRST_LIST = """@name fuzz finding (differential): a list right after the targets opened
@device 0 0x30
@device 1 0x40
@device 2 passive 8
@device 3 none
> echo 0
> debug 0
> port 0
> select
> version
> list
> version
"""


def test_a_fresh_emulator_process_starts_booted_as_the_in_process_one_does(tmp_path):
    """sil finding (--against emulator, seed 5): `P0: no device detected` on the emulator, the
    motor listed on the other side. The emulator process opened at power-on while the other side
    opened booted, and its devices (about 0.8 s of HAT time to connect) were still setting up."""
    from buildhat_conformance.fuzz.running.target_kinds import fresh_boot_options

    assert fresh_boot_options("emulator") == {"booted": True}
    assert fresh_boot_options("emulator:R7?speed=10") == {"booted": True}
    assert fresh_boot_options("emulator:latest?booted=0") == {}       # the URL's word is kept
    assert fresh_boot_options("emulator:?bootloader=1") == {}
    assert fresh_boot_options("inprocess:R7") == {}                    # booted anyway
    script = tmp_path / "differential.script"
    script.write_text(_FIRST_LIST, encoding="utf-8")
    res = _fuzz("--reproduce", str(script), "--target", "inprocess:R7", "--against", "emulator:R7",
                "--confirm", "1")
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stdout.startswith("not reproduced (0/1 replays)"), res.stdout
    # The same list is still compared: a side that lists port 0 otherwise is a finding.
    other = _fuzz("--reproduce", str(script), "--target", "inprocess:R7?device=0=none",
                  "--against", "emulator:R7", "--confirm", "1")
    assert other.returncode == 1, other.stdout + other.stderr
    assert "P0: no device detected" in other.stdout, other.stdout


def test_reproduce_says_reproduced_with_exit_1_and_not_reproduced_with_exit_0(tmp_path):
    script = _coast_script(tmp_path / "fate.script")
    bad = _fuzz("--reproduce", str(script), "--target", _proxy_url("wrong"), "--confirm", "2")
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert re.search(r"^reproduced \(2/2 replays\)", bad.stdout, re.M), bad.stdout
    good = _fuzz("--reproduce", str(script), "--target", "inprocess:R7", "--confirm", "1")
    assert good.returncode == 0, good.stdout + good.stderr
    assert good.stdout.startswith("not reproduced (0/1 replays)")
    # a finding's script names its oracle: another failure does not reproduce it
    named = tmp_path / "hygiene.script"
    named.write_text("@name fuzz finding (hygiene): something else\n" + script.read_text(encoding="utf-8"),
                     encoding="utf-8")
    other = _fuzz("--reproduce", str(named), "--target", _proxy_url("wrong"), "--confirm", "1")
    assert other.returncode == 0, other.stdout + other.stderr
    assert other.stdout.startswith("not reproduced (0/1 replays)") and "failed otherwise" in other.stdout
    missing = _fuzz("--reproduce", str(tmp_path / "nothing.script"))
    assert missing.returncode == 2 and "Traceback" not in missing.stderr


def test_a_finding_is_confirmed_shell_quoted_and_saved_to_the_database_with_a_seed(tmp_path):
    """In-process with the planted `wrong` fault (fast); the URL has a space, `&` and `?`."""
    import argparse

    from planted.faults import FAULTS

    from buildhat_conformance.emulator.targets.in_process import InProcessTarget
    from buildhat_conformance.fuzz import cli
    from buildhat_conformance.fuzz.running import from_arguments

    empty = {0: None, 1: None, 2: None, 3: None}
    url = "inprocess:R7?device=2=passive 8&seed=3"
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    out = tmp_path / "out"
    args = parser.parse_args(["--target", url, "--budget", "20x", "--seed", "4", "--steps", "6",
                              "--families", "valid", "--confirm", "2", "--shrink-time", "1", "--waits", "",
                              "--out", str(out), "--quiet", "--profile", "R7"])
    args.devices = empty
    result, files = from_arguments.run(args, primary=lambda: InProcessTarget("R7", devices=empty,
                                                                  factory=FAULTS["wrong"]))
    assert result.findings
    finding = result.findings[0]
    assert finding.attempts == 2 and 1 <= finding.reproduced <= 2
    script = pathlib.Path(files[finding.oracle]["script"]).read_text(encoding="utf-8")
    line = next(x for x in script.splitlines() if x.startswith(";; reproduce: "))
    argv = shlex.split(line[len(";; reproduce: "):])       # one shell word per argument
    assert argv[:3] == ["buildhat-conformance", "fuzz", "--reproduce"] and url in argv
    assert f";; reproduced: {finding.reproduced}/2 replays" in script
    stored = list((out / ".examples").rglob("*.json"))     # --seed still saves failing runs
    assert stored, "no failing run kept in the example database"


def test_progress_prints_plain_lines_with_elapsed_and_budget_off_a_terminal():
    stream = io.StringIO()
    progress = Progress(Budget(seconds=30), 10, set(), True, stream=stream, every=0.0)
    stats = Stats(executions=5, lines=5)
    progress(stats)
    progress(stats)
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2 and "\r" not in stream.getvalue()
    assert re.match(r"\[fuzz\] \d+/30 s: 5 inputs", lines[0]), lines


def test_differential_campaign_between_two_paced_real_time_emulators_runs_its_whole_budget(tmp_path):
    """Issue 15: this died after a few seconds with a Hypothesis traceback. Two emulators in real
    time at 115200 baud, one at double speed: their answers differ in timing, never in what is drawn."""
    target = "emulator:latest?speed=1&baud=115200"
    against = "emulator:latest?speed=2&baud=115200"
    res = _fuzz("--target", target, "--against", against, "--budget", "3s", "--steps", "10",
                "--confirm", "1", "--shrink-time", "2", "--out", str(tmp_path), "--no-database",
                timeout=300)
    assert res.returncode in (0, 1), res.stdout + res.stderr
    assert "Traceback" not in res.stderr and "Flaky" not in res.stdout + res.stderr
    m = SUMMARY.search(res.stdout)
    assert m is not None, res.stdout
    assert float(m.group(5)) >= 3.0             # ran the whole budget
    assert "wire: sent" in res.stdout           # the share of the wire it used


def test_a_finding_on_a_link_target_is_shrunk_by_replaying_smaller_scripts(tmp_path):
    """The planted `wrong` fault as a `cmd:` byte proxy (a process, kept open from run to run)."""
    from buildhat_conformance.fuzz.findings.shrink import steps_of
    from buildhat_conformance.transcripts.script import load_script

    res = _fuzz("--target", _proxy_url("wrong"), "--budget", "10x", "--seed", "4", "--steps", "4",
                "--batch", "4", "--families", "valid", "--confirm", "1", "--shrink-time", "120",
                "--waits", "", "--out", str(tmp_path), "--quiet", timeout=300)
    assert res.returncode == 1, res.stdout + res.stderr
    script = load_script(str(next(tmp_path.glob("*.script"))))
    steps = steps_of(script)
    assert len(steps) <= 3, [a.text for a in script.actions]         # the prelude, set-up, the step
    assert any(a.data.lstrip(b" ;").lower().startswith(b"co") for a in steps[-1] if a.kind == "send"), \
        [a.text for a in steps[-1]]

"""Every sub-command meets the same mistakes the same way: one line on stderr, no traceback,
the exit status of the team contract (2 usage, 3 target unreachable).

The matrix calls the command's own ``main`` in this process (a traceback would fail the test
as an exception); the cases that start a run use a real process, as a user runs them.
"""
from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "transcripts" / "abbreviation.script"
TRANSCRIPT = ROOT / "transcripts" / "abbreviation.jsonl"


def _cli(args, cwd):
    proc = subprocess.run([sys.executable, "-m", "buildhat_conformance", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, PYTHONWARNINGS="ignore"))
    return proc.returncode, proc.stdout, proc.stderr


def _main(args, cwd, monkeypatch, capsys):
    from buildhat_conformance.cli import main

    monkeypatch.chdir(cwd)
    try:
        rc = main([str(a) for a in args])
    except SystemExit as exc:     # argparse's own exit
        rc = exc.code
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


def _one_line(err: str) -> bool:
    return len([line for line in err.splitlines() if line.strip()]) == 1


# The commands that take a target, each with what it needs besides the target.
TARGETED = {
    "run": ["--junit", "r/junit.xml"],
    "script": [SCRIPT, "-o", "out.jsonl"],
    "fuzz": ["--budget", "1x", "--out", "f"],
    "record": [SCRIPT, "-o", "out.jsonl"],
    "replay": [TRANSCRIPT],
    "load": [SCRIPT, SCRIPT],       # files that exist; the target is refused before they are sent
}
# What a sub-command reads, given as a file that does not exist.
MISSING_FILE = {
    "run": ["--inventory", "nope.txt", "--junit", "r/junit.xml"],
    "script": ["nope.script", "-t", "inprocess"],
    "record": ["nope.script", "-t", "inprocess", "-o", "x.jsonl"],
    "replay": ["nope.jsonl", "-t", "inprocess"],
    "mock": ["nope.jsonl"],
    "report": ["nope.xml", "-o", "x.html"],
    "load": ["nope.bin", "nope.sig", "-t", "inprocess"],
}
# An option value of the wrong type, for every sub-command.
BAD_VALUE = {
    "run": ["--speed", "fast"],
    "script": [SCRIPT, "--open-timeout", "soon"],
    "fuzz": ["--seed", "abc"],
    "record": [SCRIPT, "--boot-timeout", "soon"],
    "replay": [TRANSCRIPT, "--boot-timeout", "soon"],
    "mock": [TRANSCRIPT, "--speed", "fast"],
    "report": [],                                   # no JUNIT at all
    "targets": ["--bogus"],
    "bench": ["--runs", "many"],
}

CASES = (
    [(f"{cmd} unknown target", [cmd, *rest, "-t", "nosuch:thing"], 2) for cmd, rest in TARGETED.items()]
    + [(f"{cmd} unknown release", [cmd, *rest, "-t", "emulator:R9"], 2) for cmd, rest in TARGETED.items()]
    + [(f"{cmd} no such device", [cmd, *rest, "-t", "/dev/ttyNOPE"], 3) for cmd, rest in TARGETED.items()]
    + [(f"{cmd} not a serial device", [cmd, *rest, "-t", "/dev/null"], 3) for cmd, rest in TARGETED.items()]
    + [(f"{cmd} nothing listening", [cmd, *rest, "-t", "socket://127.0.0.1:1"], 3)
       for cmd, rest in TARGETED.items()]
    + [(f"{cmd} missing file", [cmd, *rest], 2) for cmd, rest in MISSING_FILE.items()]
    + [(f"{cmd} bad option value", [cmd, *rest], 2) for cmd, rest in BAD_VALUE.items()]
    + [("run bad --firmware", ["run", "--firmware", "banana", "--junit", "r/junit.xml"], 2)]
    # an output that cannot be written (a file stands where a folder must be)
    + [("run unwritable --junit", ["run", "--junit", "r/junit.xml/j.xml"], 2),
       ("run unwritable --transcripts", ["run", "--transcripts", "r/junit.xml/t", "--junit", "r/x.xml"], 2),
       ("script unwritable -o", ["script", SCRIPT, "-t", "inprocess", "-o", "r/junit.xml/o.jsonl"], 2),
       ("record unwritable -o", ["record", SCRIPT, "-t", "inprocess", "-o", "r/junit.xml/o.jsonl"], 2),
       ("replay unwritable -o", ["replay", TRANSCRIPT, "-t", "inprocess", "-o", "r/junit.xml/o.jsonl"], 2),
       ("fuzz unwritable --out", ["fuzz", "-t", "inprocess", "--budget", "1x", "--out", "r/junit.xml/f"], 2),
       ("bench unwritable -o", ["bench", "--quick", "-o", "r/junit.xml/b.json"], 2)]
    + [("bench unknown group", ["bench", "--quick", "-k", "nosuchgroup"], 2)]
)


@pytest.mark.parametrize("name,args,status", CASES, ids=[c[0] for c in CASES])
def test_the_same_mistake_is_one_line_and_the_same_status(tmp_path, monkeypatch, capsys, name, args, status):
    previous = tmp_path / "r" / "junit.xml"          # the report of an earlier run
    previous.parent.mkdir()
    previous.write_text("<testsuites/>", encoding="utf-8")
    rc, _out, err = _main(args, tmp_path, monkeypatch, capsys)
    assert "Traceback" not in err, err
    assert _one_line(err), f"{name}: {err!r}"
    assert rc == status, f"{name}: exit {rc}, stderr {err!r}"
    assert sorted(p.name for p in previous.parent.iterdir()) == ["junit.xml"], "a refused run wrote a report"
    assert previous.read_text(encoding="utf-8") == "<testsuites/>", "a refused run touched the report"


def test_a_bad_transcript_field_names_file_and_line(tmp_path, monkeypatch, capsys):
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"dir":"meta","firmware":"x"}\n{"t":"x","dir":"host","bytes":"version\\r"}\n')
    for cmd in (["replay", bad, "-t", "inprocess"], ["mock", bad]):
        rc, _out, err = _main(cmd, tmp_path, monkeypatch, capsys)
        assert rc == 2 and _one_line(err) and "Traceback" not in err
        assert f"{bad}:2: 't' must be a number" in err, err


def test_a_script_that_is_not_text_names_file_and_line(tmp_path, monkeypatch, capsys):
    bad = tmp_path / "bad.script"
    bad.write_bytes(b"> vin\n> \xff\xfe\n")
    for cmd in (["script", bad, "-t", "inprocess"], ["record", bad, "-t", "inprocess", "-o", "o.jsonl"]):
        rc, _out, err = _main(cmd, tmp_path, monkeypatch, capsys)
        assert rc == 2 and _one_line(err) and "Traceback" not in err, err
        assert f"{bad}:2: not UTF-8 text" in err, err


def test_report_of_a_broken_junit_file_is_one_line(tmp_path, monkeypatch, capsys):
    (tmp_path / "bad.xml").write_text("<testsuites><testsuite", encoding="utf-8")
    rc, _out, err = _main(["report", "bad.xml", "-o", "x.html"], tmp_path, monkeypatch, capsys)
    assert rc == 2 and _one_line(err) and "Traceback" not in err and "bad.xml" in err, err


def test_a_silent_target_is_one_line_before_any_case(tmp_path):
    """Something listens but never answers: exit 3 in one line, no report written."""
    silent = tmp_path / "silent.py"
    silent.write_text("import sys, time\nsys.stdin.read()\n", encoding="utf-8")
    rc, out, err = _cli(["run", "-t", f"cmd:{sys.executable} {silent}", "--junit", "r/junit.xml"], tmp_path)
    assert rc == 3 and _one_line(err) and "nothing answering" in err, (rc, err)
    assert not (tmp_path / "r").exists() and "passed" not in out


def test_firmware_judges_as_and_says_so(tmp_path):
    """A build no release matches, --firmware R2: judged as R2, and both are said. (A known
    release judged as another exits 3 in one line: tests/test_conformance_wrong_answers.py.)"""
    rc, out, err = _cli(["run", "-t", "inprocess:R7?version=1737600000", "--firmware", "R2", "-k",
                         "test_version", "--junit", "r/junit.xml"], tmp_path)
    assert "Traceback" not in err
    assert "runs firmware 1737600000" in err and "judged as R2" in err, err
    junit = (tmp_path / "r" / "junit.xml").read_text(encoding="utf-8")
    assert 'name="firmware" value="1737600000' in junit and 'name="judged_as" value="R2' in junit


def test_help_is_plain_text_and_names_the_default_target(tmp_path, monkeypatch, capsys):
    from buildhat_conformance.harness.cli_dispatch import SUBCOMMANDS

    # fuzz keeps inprocess as its default for now (h15-fuzz's choice; see the h16-cli report)
    for args in (["--help"], ["run", "--help"], ["script", "--help"]):
        rc, out, _err = _main(args, tmp_path, monkeypatch, capsys)
        assert "emulator:latest?speed=10" in " ".join(out.split()), out
    for name in SUBCOMMANDS:
        rc, out, _err = _main([name, "--help"], tmp_path, monkeypatch, capsys)
        assert rc == 0 and "`" not in out, f"{name} --help is not plain text:\n{out}"
        if name in TARGETED:
            assert "-t URL, --target URL" in out, f"{name} --help has no -t/--target:\n{out}"

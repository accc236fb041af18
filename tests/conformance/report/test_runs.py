"""Run folders (conformance/report/runs.py) through the real ``buildhat-conformance run``: each run
writes its own folder, ``reports/latest`` and the well-known copies follow only runs where
cases ran, and old runs can be listed and pruned."""
from __future__ import annotations

import datetime
import os
import subprocess
import sys

import pytest

from buildhat_conformance.conformance.report import runs

pytestmark = pytest.mark.timeout(300)

CASE = "test_vin_prints_volts_with_two_decimals"


def conformance(cwd, *args: str) -> subprocess.CompletedProcess:
    argv = [sys.executable, "-m", "buildhat_conformance.cli", *args]
    return subprocess.run(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=240,
                          text=True)


def snapshot(root) -> dict:
    """Every file under reports/ with its bytes and mtime, and where latest points."""
    out = {}
    for d, _s, files in os.walk(root):
        for f in files:
            p = os.path.join(d, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, root)] = (fh.read(), os.stat(p).st_mtime_ns)
    out["<latest>"] = runs.resolve_latest(str(root))
    return out


def test_each_run_has_its_folder_and_nothing_ran_changes_nothing(tmp_path) -> None:
    reports = tmp_path / "reports"
    first = conformance(tmp_path, "run", "--target", "inprocess", "-k", CASE)
    assert first.returncode == 0, first.stdout[-3000:]
    [folder] = os.listdir(reports / "runs")
    assert folder.endswith("-inprocess"), folder
    run_dir = reports / "runs" / folder
    assert runs.resolve_latest(str(reports)) == os.path.realpath(run_dir)
    assert (reports / "junit.xml").read_bytes() == (run_dir / "junit.xml").read_bytes()
    assert (reports / "index.html").read_bytes() == (run_dir / "index.html").read_bytes()
    assert os.listdir(run_dir / "transcripts"), "the run's transcripts are in its folder"
    assert not (reports / "transcripts").exists()
    assert f"run folder: {run_dir}" in first.stdout

    before = snapshot(reports)
    nothings = (["-k", "nosuchtest"], ["--collect-only", "-k", CASE], ["nosuchfile.py::test_x"])
    # Side by side (each makes and removes its own run folder): the machine has two cores.
    argv = [sys.executable, "-m", "buildhat_conformance.cli", "run", "--target", "inprocess"]
    procs = [subprocess.Popen(argv + nothing, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True) for nothing in nothings]
    outs = [p.communicate(timeout=240)[0] for p in procs]
    for nothing, out in zip(nothings, outs):
        assert "no test case ran" in out, (nothing, out[-2000:])
    assert snapshot(reports) == before, f"one of {nothings} changed reports/: {outs}"

    second = conformance(tmp_path, "run", "--target", "inprocess", "-k", CASE)
    assert second.returncode == 0, second.stdout[-3000:]
    folders = sorted(os.listdir(reports / "runs"))
    assert len(folders) == 2 and runs.resolve_latest(str(reports)) == os.path.realpath(
        reports / "runs" / folders[-1])
    assert runs.previous_junit(str(reports / "runs" / folders[-1] / "junit.xml")) == str(
        reports / "runs" / folders[0] / "junit.xml")
    html = (reports / "index.html").read_text(encoding="utf-8")
    assert f"Since the previous run of this target ({folders[0]}): no verdict changed." in html

    listed = conformance(tmp_path, "report", "--list")
    assert [ln.split()[0] for ln in listed.stdout.splitlines()] == folders, listed.stdout
    assert "<- latest" in listed.stdout.splitlines()[-1] and "1 pass" in listed.stdout
    pruned = conformance(tmp_path, "report", "--prune", "1")
    assert pruned.returncode == 0 and os.listdir(reports / "runs") == folders[-1:], pruned.stdout


def test_explicit_junit_writes_where_it_is_told(tmp_path) -> None:
    junit = tmp_path / "ci" / "result.xml"
    proc = conformance(tmp_path, "run", "--target", "inprocess", "-k", CASE, "--junit", str(junit))
    assert proc.returncode == 0, proc.stdout[-3000:]
    assert junit.is_file() and (tmp_path / "ci" / "index.html").is_file()
    assert not (tmp_path / "reports").exists()


def _fake_run(root, name: str, target: str, cases: int = 1) -> str:
    path = os.path.join(root, "runs", name)
    os.makedirs(path)
    body = "".join(f'<testcase classname="c" name="t{i}" time="0"/>' for i in range(cases))
    with open(os.path.join(path, "junit.xml"), "w", encoding="utf-8") as fh:
        fh.write(f'<testsuites><testsuite name="s" tests="{cases}"><properties>'
                 f'<property name="target" value="{target}"/></properties>{body}</testsuite></testsuites>')
    return path


def test_previous_run_is_the_same_targets_and_one_that_ran(tmp_path) -> None:
    a = _fake_run(tmp_path, "20260101T000000Z-emulator", "emulator:latest")
    _fake_run(tmp_path, "20260102T000000Z-serial", "/dev/ttyAMA0")
    _fake_run(tmp_path, "20260103T000000Z-emulator", "emulator:latest", cases=0)
    d = _fake_run(tmp_path, "20260104T000000Z-emulator", "emulator:latest")
    assert runs.previous_junit(os.path.join(d, "junit.xml")) == os.path.join(a, "junit.xml")
    assert runs.previous_junit(os.path.join(a, "junit.xml")) is None
    assert runs.previous_junit(str(tmp_path / "junit.xml")) is None    # not in a run folder


def test_latest_falls_back_to_a_text_file_without_symlinks(tmp_path, monkeypatch) -> None:
    def no_symlinks(*_a, **_k):
        raise OSError("symlinks not supported here")
    monkeypatch.setattr(os, "symlink", no_symlinks)
    folder = runs.start(str(tmp_path), ["serial:///dev/ttyAMA0?baud=115200"],
                        now=datetime.datetime(2026, 11, 24, 20, 0, tzinfo=datetime.timezone.utc))
    assert folder.name == "20261124T200000Z-serial_dev_ttyAMA0_baud_115200"
    with open(folder.junit, "w", encoding="utf-8") as fh:
        fh.write('<testsuites><testsuite name="s" tests="1"><testcase classname="c" name="t"/>'
                 "</testsuite></testsuites>")
    runs.finish(folder)
    assert (tmp_path / "latest").is_file() and not (tmp_path / "latest").is_symlink()
    assert runs.resolve_latest(str(tmp_path)) == folder.path


def test_transcripts_of_the_earlier_layout_move_into_a_run_folder(tmp_path) -> None:
    (tmp_path / "transcripts").mkdir()
    (tmp_path / "transcripts" / "old.jsonl").write_text("{}\n")
    (tmp_path / "junit.xml").write_text("<testsuites/>")
    folder = runs.start(str(tmp_path), ["emulator"])
    with open(folder.junit, "w", encoding="utf-8") as fh:
        fh.write('<testsuites><testsuite name="s" tests="1"><testcase classname="c" name="t"/>'
                 "</testsuite></testsuites>")
    runs.finish(folder)
    assert not (tmp_path / "transcripts").exists()
    [old] = [n for n in os.listdir(tmp_path / "runs") if n.endswith("-earlier-layout")]
    assert (tmp_path / "runs" / old / "transcripts" / "old.jsonl").read_text() == "{}\n"
    assert (tmp_path / "junit.xml").read_bytes() == open(folder.junit, "rb").read()

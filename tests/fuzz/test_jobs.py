"""`fuzz --jobs N`: N campaign workers, each with targets of its own, one summary.

Worker w of N takes the run indexes w, w+N, ... of the campaign seed, so a run budget runs the
same runs as one campaign: the same inputs and lines, in N processes."""
from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys

from buildhat_conformance.fuzz import cli
from buildhat_conformance.fuzz.oracles.registry import finding_class
from buildhat_conformance.fuzz.running import from_arguments
from buildhat_conformance.fuzz.running.campaign import CampaignResult, Confirmed
from buildhat_conformance.fuzz.running.checked_run import Stats
from buildhat_conformance.fuzz.running.workers import merge_results, merge_stats
from buildhat_conformance.transcripts.script import Script

EXE = os.path.join(os.path.dirname(sys.executable), "buildhat-conformance")


def _args(out: pathlib.Path, *extra: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    target = "inprocess:R7?device=0=0x30&device=1=none&device=2=none&device=3=none"
    return parser.parse_args(["--target", target, "--out", str(out), "--no-database", "--quiet",
                              "--seed", "11", "--steps", "12", *extra])


def test_a_run_budget_over_two_workers_runs_the_same_runs(tmp_path, monkeypatch):
    seen = []
    summary = from_arguments.print_summary
    monkeypatch.setattr(from_arguments, "print_summary", lambda result, stats, *rest: (seen.append(stats),
                                                                            summary(result, stats, *rest)))
    one, _ = from_arguments.run(_args(tmp_path / "one", "--budget", "6x"))
    two, _ = from_arguments.run(_args(tmp_path / "two", "--budget", "6x", "--jobs", "2"))
    one_stats, two_stats = seen
    assert not one.findings and not two.findings
    assert (one.runs, two.runs, two.workers) == (6, 6, 2)
    # The same runs, drawn from the same seeds: the same inputs and lines, whoever ran them.
    assert two_stats.executions > 0
    assert (two_stats.executions, two_stats.lines) == (one_stats.executions, one_stats.lines)
    assert two_stats.productions == one_stats.productions


def test_merged_figures_add_up_and_one_finding_per_oracle_is_kept():
    a = Stats(executions=3, lines=5, productions={"x"}, checks={"fate": 2}, checking_s=1.0)
    b = Stats(executions=4, lines=6, productions={"y"}, checks={"fate": 1, "state": 1}, checking_s=3.0)
    merged = merge_stats([a, b])
    assert (merged.executions, merged.lines, merged.productions) == (7, 11, {"x", "y"})
    assert merged.checks == {"fate": 3, "state": 1} and merged.checking_s == 3.0

    def confirmed(oracle: str, seed: int) -> Confirmed:
        return Confirmed(finding_class(oracle)("m", [], {}), Script(), 1, 1, seed)
    first = CampaignResult(seed=1, runs=2, elapsed=10.0, cpu=4.0, findings=[confirmed("fate", 1)])
    second = CampaignResult(seed=1, runs=3, elapsed=9.0, cpu=5.0,
                            findings=[confirmed("fate", 2), confirmed("state", 3)])
    result = merge_results([first, second], merged)
    assert [(f.oracle, f.run_seed, f.also_seen) for f in result.findings] == [("fate", 1, 1), ("state", 3, 0)]
    assert (result.runs, result.elapsed, result.cpu, result.workers) == (5, 10.0, 9.0, 2)


def test_jobs_need_targets_started_anew_and_say_so_in_one_line(tmp_path):
    done = subprocess.run([EXE, "fuzz", "--target", "/dev/ttyNONE", "--jobs", "2", "-o", str(tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "--jobs 2" in lines[0] and "--places" in lines[0], done.stderr
    done = subprocess.run([EXE, "fuzz", "--jobs", "0", "-o", str(tmp_path)], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr


def _auto(monkeypatch, cpus: int, *argv: str, env: str = "") -> int:
    from buildhat_conformance.fuzz.running import worker_count

    monkeypatch.setattr(worker_count, "_usable_cpus", lambda: cpus)
    if env:
        monkeypatch.setenv(worker_count.JOBS_ENV, env)
    else:
        monkeypatch.delenv(worker_count.JOBS_ENV, raising=False)
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    return worker_count.resolve_jobs(parser.parse_args(list(argv)), from_arguments.DEFAULT_TARGET)


def test_jobs_auto_is_a_worker_per_cpu_for_hats_this_program_starts(monkeypatch):
    sil = "sil:/some/tree"
    assert _auto(monkeypatch, 2, "-t", sil, "--against", "emulator") == 2
    assert _auto(monkeypatch, 4, "-t", "inprocess") == 4
    assert _auto(monkeypatch, 2) == 2                              # the default target: the emulator
    assert _auto(monkeypatch, 64, "-t", sil) == 8                  # at most AUTO_JOBS_MAX
    assert _auto(monkeypatch, 1, "-t", sil) == 1
    assert _auto(monkeypatch, 4, "-t", sil, env="3") == 3          # $BUILDHAT_CONFORMANCE_JOBS
    assert _auto(monkeypatch, 4, "-t", sil, "--jobs", "1") == 1    # said outright
    # One HAT (a port, a socket), or perhaps one (a user's cmd:): one worker.
    assert _auto(monkeypatch, 4, "-t", "/dev/ttyAMA0") == 1
    assert _auto(monkeypatch, 4, "-t", sil, "--against", "socket://pi:4000") == 1
    assert _auto(monkeypatch, 4, "-t", "cmd:ssh pi hat-bridge") == 1
    assert _auto(monkeypatch, 4, "-t", sil, "--reproduce", "x.script") == 1


def test_a_bad_jobs_value_is_one_line_and_exit_2(monkeypatch):
    from buildhat_conformance.plumbing.cli_options import UsageError

    try:
        _auto(monkeypatch, 4, "-t", "inprocess", env="0")
    except UsageError as exc:
        assert "BUILDHAT_CONFORMANCE_JOBS" in str(exc)
    else:
        raise AssertionError("$BUILDHAT_CONFORMANCE_JOBS=0 was taken")
    env = {k: v for k, v in os.environ.items() if k != "BUILDHAT_CONFORMANCE_JOBS"}
    done = subprocess.run([EXE, "fuzz", "-t", "inprocess", "--jobs", "two"], capture_output=True,
                          text=True, env=env, timeout=60)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "a number of workers or 'auto', not 'two'" in done.stderr


def test_the_default_command_runs_a_worker_per_cpu_and_says_so(tmp_path):
    """Through the user's command, with nothing set: a fuzz of the in-process emulator runs one
    worker per usable CPU (at most 8), and its first line and summary say how many."""
    env = {k: v for k, v in os.environ.items() if k != "BUILDHAT_CONFORMANCE_JOBS"}
    done = subprocess.run([EXE, "fuzz", "-t", "inprocess", "--budget", "4x", "--seed", "3", "--no-database",
                           "--out", str(tmp_path)], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr + done.stdout
    cpus = min(len(os.sched_getaffinity(0)), 8)
    if cpus > 1:
        assert f", {cpus} workers (--jobs auto" in done.stderr, done.stderr
        assert f"  {cpus} workers: " in done.stdout, done.stdout
    else:
        assert "workers" not in done.stderr + done.stdout

"""`fuzz --jobs N`: N campaign workers, each with targets of its own, one summary.

Worker w of N takes the run indexes w, w+N, ... of the campaign seed, so a run budget runs the
same runs as one campaign: the same inputs and lines, in N processes."""
from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys

from buildhat_conformance.fuzz import cli, command
from buildhat_conformance.fuzz.campaign import CampaignResult, Confirmed
from buildhat_conformance.fuzz.jobs import merge_results, merge_stats
from buildhat_conformance.fuzz.oracles import finding_class
from buildhat_conformance.fuzz.runner import Stats
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
    summary = command.print_summary
    monkeypatch.setattr(command, "print_summary", lambda result, stats, *rest: (seen.append(stats),
                                                                            summary(result, stats, *rest)))
    one, _ = command.run(_args(tmp_path / "one", "--budget", "6x"))
    two, _ = command.run(_args(tmp_path / "two", "--budget", "6x", "--jobs", "2"))
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

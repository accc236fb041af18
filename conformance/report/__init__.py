"""Reports from JUnit files: the requirement coverage matrix, per-profile results, known
deviations, failures with their transcript, and plots. :func:`build_report` is what the
conformance runner calls after a run; ``buildhat-conformance report`` is its command line."""
from __future__ import annotations

import os
from typing import TYPE_CHECKING, Dict, List, Optional, Sequence, Tuple

if TYPE_CHECKING:     # the report's modules load on first use: a run imports this package early
    from .junit import Case, JunitRun
    from .page import Triage
    from .plots import Plot
    from .triage import Change

__all__ = ["build_report"]

MAX_PLOTS = 12   # a report is for reading; more plots than this bury the first ones
MIN_SAMPLES = 10  # fewer debug 16 lines than this (a case that just passed through PID) show nothing
# Cases whose requirements are about the controller come first: their plots are the point.
_PLOT_FIRST = ("CMD-PID", "CMD-SET", "EX-MOTOR")


def _plots(runs, max_plots: int) -> list:  # type: ignore[no-untyped-def]
    """Plots of the runs' transcripts: controller cases first, one per transcript, each with
    enough samples to show something."""
    from .plots import plots_for_transcript

    cases = [(run, c) for run in runs for c in run.cases if c.transcript and os.path.isfile(c.transcript)]
    cases.sort(key=lambda rc: not any(r.startswith(_PLOT_FIRST) for r in rc[1].requirements))
    out: list = []
    seen = set()
    per_test: Dict[str, int] = {}
    for run, case in cases:
        if len(out) >= max_plots:
            break
        base = case.name.split("[", 1)[0]
        if case.transcript in seen or per_test.get(base, 0) >= 2:   # a few of each parametrized test
            continue
        seen.add(case.transcript)
        label = f"{case.name} ({run.profile or run.label})"
        try:
            found = plots_for_transcript(case.transcript, label=label, min_samples=MIN_SAMPLES)
        except (OSError, ValueError):
            continue
        if found:
            per_test[base] = per_test.get(base, 0) + 1
        out.extend(found[:max_plots - len(out)])
    return out


def _triage(all_runs: List[JunitRun], failures: List[Tuple[JunitRun, Case]]) -> Triage:
    """The first screen's data: failure groups, changes since each run's previous run of the
    same target (when it lives in a run folder), deviation explanations, requirement statements."""
    from ...protocol.requirements import requirements
    from ..deviations import deviations
    from .junit import read_junit
    from .page import Triage
    from .runs import previous_junit
    from .triage import changes_since, group_failures

    changes: Dict[str, Optional[Tuple[str, List[Change]]]] = {}
    for run in all_runs:
        prev = previous_junit(run.path)
        if prev:
            try:
                changes[run.path] = (os.path.basename(os.path.dirname(prev)),
                                     changes_since(read_junit(prev), run))
            except (OSError, ValueError, SyntaxError):   # ElementTree's ParseError is a SyntaxError
                changes[run.path] = None
        else:
            changes[run.path] = None
    explained = {k: (d.explain, d.reference) for k, d in deviations().items()}
    statements = {r.id: r.statement for r in requirements()}
    return Triage(group_failures(failures), changes, explained, statements)


def _timing_plots(runs: List[JunitRun]) -> List[Plot]:
    from .plots import timing_plots
    from .timing import collect_timing

    paths = [(c.transcript, c.name) for run in runs for c in run.cases
             if c.transcript and os.path.isfile(c.transcript)]
    return timing_plots(collect_timing(paths))


def build_report(junit_paths: Sequence[str], out_path: str, max_plots: int = MAX_PLOTS) -> str:
    """Write the HTML report for one or more JUnit files; returns ``out_path``."""
    from ...plumbing.package_version import __version__
    from .excerpt import excerpt_lines
    from .junit import read_junit
    from .page import render_html
    from .requirement_coverage import coverage

    if not junit_paths:
        raise ValueError("build_report needs at least one JUnit file")
    runs = [read_junit(os.fspath(p)) for p in junit_paths]
    excerpts: Dict[int, List[str]] = {}
    for run in runs:
        for case in run.cases:
            path = case.transcript
            if case.verdict in ("fail", "known_deviation", "target_fault") and path and os.path.isfile(path):
                t: Optional[float] = None
                raw_t = case.prop("transcript_t") or case.prop("fail_t")
                if raw_t:
                    try:
                        t = float(raw_t)
                    except ValueError:
                        t = None
                try:
                    excerpts[id(case)] = excerpt_lines(path, around_t=t)
                except (OSError, ValueError):
                    pass
    failures = [(r, c) for r in runs for c in r.cases if c.verdict == "fail"]
    plots = _timing_plots(runs) + _plots(runs, max_plots)
    text = render_html(runs, coverage(runs), excerpts, plots, __version__,
                       _triage(runs, failures))
    os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
    with open(out_path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return out_path

"""A pytest plugin for the suite's runs in `sil mutate`: stop at the first failing case, and run
the usual killers first.

``--stop-at-fail``: the run ends after the first case whose verdict is ``fail``, which is all a
mutant's verdict (killed) needs. Unlike pytest's ``-x`` a target fault does not stop it: a mutant
that makes one case fault and a later one fail is killed by that failing case, not "killed by a
fault" (the plugin's ``--max-target-faults`` still gives up on a HAT that keeps faulting).

A killed mutant's run stops at its first failing case, so the sooner a case that kills many
mutants runs, the cheaper the campaign. ``--case-order FILE`` (one pytest node id a line, first
= soonest) puts the listed cases first, in that order, and the others after them as collected;
the plugin's link clauses still run before everything (their sort is stable and comes after
this one). Every run of one campaign, the unmutated reference runs included, gets the same
order, so the HAT's lines of a case are compared between runs that led up to it alike.

:func:`killers` ranks the cases of an earlier campaign's ``mutation.json`` by the mutants they
killed.
"""
from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any, List

import pytest

__all__ = ["killers", "pytest_addoption", "pytest_collection_modifyitems", "pytest_sessionstart",
           "pytest_runtest_logreport"]

_session: List[Any] = []        # the running session (one per process), for its shouldfail


def killers(summary: Path) -> List[str]:
    """The cases that killed mutants in the campaign ``summary`` (a mutation.json), most
    kills first; their names as the JUnit file gives them (``module::case[param]``)."""
    data = json.loads(summary.read_text(encoding="utf-8"))
    counts: Counter = Counter()
    for m in data.get("mutants", []):
        if m.get("status") == "killed" and m.get("cases"):
            counts[m["cases"][0]] += 1            # the first failing case: the one that stopped it
    return [case for case, _n in counts.most_common()]


def pytest_addoption(parser: Any) -> None:
    parser.addoption("--case-order", default=None, metavar="FILE",
                     help="run the cases named in FILE (one a line, module::case[param]) first, in order")
    parser.addoption("--stop-at-fail", action="store_true", default=False,
                     help="end the run after the first failing case (a target fault does not stop it)")


def pytest_sessionstart(session: Any) -> None:
    _session[:] = [session]


def pytest_runtest_logreport(report: Any) -> None:
    """A failed phase that the conformance plugin did not call a target fault is a ``fail``
    verdict; the session then ends after this case, as with ``-x``."""
    if not report.failed or not _session or "target_fault" in dict(report.user_properties):
        return
    session = _session[0]
    if session.config.getoption("--stop-at-fail"):
        session.shouldfail = f"stopped at the first failing case: {report.nodeid}"


def _name(item: Any) -> str:
    """``module::case[param]``, the JUnit file's classname::name as `sil mutate` keeps it."""
    module = Path(str(item.fspath)).stem
    return f"{module}::{item.name}"


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: Any, items: List[Any]) -> None:
    path = config.getoption("--case-order")
    if not path:
        return
    rank = {name: i for i, name in enumerate(Path(path).read_text(encoding="utf-8").split("\n")) if name}
    last = len(rank)
    items[:] = sorted(items, key=lambda item: rank.get(_name(item), last))

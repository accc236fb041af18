"""The fixtures every conformance case gets: the shared ``hat`` and, per case, its own transcript,
the resynchronising fence, its verdict and its JUnit properties. The run they draw on (one session,
verdicts, fault counting) is plugin/run.py."""
from __future__ import annotations

import os
from typing import Any

import pytest

from ..hat_under_test import HatUnderTest
from ..setup_check import SetupRefused
from ..target_fault import first_line
from ..trusted_clauses import MARKER as CLAUSE_MARKER
from ..verdict import Verdict
from .run import (
    CannotJudge,
    SuiteRun,
    _call_failed_key,
    _not_run_key,
    _run_key,
    _verdict_key,
    requirement_ids,
    transcript_name,
)
from .summary import firmware_of

__all__ = ["hat"]


# -- fixtures ------------------------------------------------------------------------------
@pytest.fixture(scope="session")
def _run(pytestconfig: Any) -> SuiteRun:
    return pytestconfig.stash[_run_key]


@pytest.fixture
def hat(_run: SuiteRun) -> HatUnderTest:
    """The HAT under test, shared by every case (opened once, closed at the end). Function-scoped
    as a fixture (the session is cached by the run) so that a target that could not be opened is
    a target fault once, not an error cached for every later case."""
    return _run.open()


@pytest.fixture(autouse=True)
def _conformance_case(request: Any, _run: SuiteRun) -> Any:
    """Per case: its own transcript, the resynchronising fence, and its JUnit properties."""
    from ...harness.transcript import TranscriptWriter

    item = request.node
    ids = requirement_ids(item)
    item.user_properties.extend([("requirements", ",".join(ids)), ("target", _run.url)])
    if _run.stopped is None and _run.tee is not None and _run.tee.dead:
        _run.stopped = f"the target went away ({first_line(_run.tee.dead)})"
    if _run.stopped is None and _run.reset_due is not None:
        _run.recover()
    if _run.stopped is None and _run.hat is None:
        try:
            _run.open()
        except CannotJudge:
            pass                # stopped: said below, as for every later case
    broken = _run.broken
    clause = item.get_closest_marker(CLAUSE_MARKER)
    if broken is not None and (clause.args[0] == broken.clause if broken.clause and clause is not None
                               else not broken.clause and broken.requirement in ids):
        pytest.fail(broken.finding, pytrace=False)    # a case of the broken clause: a finding
    if _run.stopped is not None:
        item.stash[_not_run_key] = _run.stopped
        pytest.skip(f"not run: {_run.stopped}")
    hat = _run.open()
    assert _run.tee is not None
    between = hat.between
    # A build of the user's profiles file deviates from the document as the release it starts from.
    verdict = Verdict(hat.profile.base or hat.profile.name,
                      (between[0].base or between[0].name, between[1].base or between[1].name) if between
                      else None)
    item.stash[_verdict_key] = verdict
    path = os.path.join(_run.transcripts, transcript_name(item.nodeid) + ".jsonl")
    p = hat.profile
    item.user_properties.extend([
        ("firmware", firmware_of(hat)),
        ("profile", hat.profile_label), ("transcript", path)])
    if between:
        verdict.note(f"unknown build between {between[0].name} and {between[1].name}: judged by the "
                     "document; where they differ, informational")
    elif not hat.profile_exact:
        verdict.note(f"judged as {p.name}: {hat.profile_why or 'unknown firmware version'}")
    writer = TranscriptWriter(path, {"firmware": firmware_of(hat), "target": _run.url, "case": item.nodeid,
                                     "requirements": ids, "profile": p.name})
    _run.tee.switch(writer)
    waited = getattr(hat.session, "waited_hat_ms", 0.0)   # H10: see Session.note_wait
    restarts = hat.restarts
    try:
        try:
            hat.resync()
        except SetupRefused as exc:      # nothing can begin from a known state: the run's failure
            _run.no_job = str(exc)
            _run.stopped = str(exc)
            item.stash[_not_run_key] = _run.stopped
            pytest.skip(f"not run: {exc}")
        if hat.restarts > restarts:
            verdict.note("the HAT restarted before this case; the suite's set-up was restored")
        if hat.setup_said:               # a set-up command refused: said once, in one line each
            for line in hat.setup_said:
                verdict.note(line)
            hat.setup_said = []
            _run.junit.set_property("setup_refused", " | ".join(hat.setup_check.said))
        yield
        if not item.stash.get(_call_failed_key, False):
            hat.check_reboot()     # a restart late in a case that did not fence after it
    finally:
        _run.after_case_firmware(item)     # a firmware in the loop: its reports; started again if it crashed
        if _run.tee is not None:
            _run.tee.switch(None)
        writer.close()
        # H10 (make bench): the HAT time this case had to wait, summed by bench/suite.py.
        item.user_properties.append(
            ("hat_wait_ms", f"{getattr(hat.session, 'waited_hat_ms', 0.0) - waited:.1f}"))

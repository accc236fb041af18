"""The run, a part of the suite's pytest plugin: the shared HAT session, a verdict class per
case, target faults counted, an always-valid JUnit file and a per-requirement summary. The
options are plugin/options.py; the fixtures every case gets, plugin/case_fixtures.py.

Target faults (conformance/target_fault.py) get the verdict ``target-fault``: a JUnit
``<error>`` whose message is one line saying what the target did. After N of them in a row the
run stops talking to the target and every remaining case is reported ``not-run`` (a JUnit
``<skipped>``) with the reason, so a hung HAT costs N cases, not the rest of the run. Before
that, a target that can reset the HAT is reset once (conformance/plugin/recovery.py: ``--image`` and
``--signature`` load the release again after it), and the run goes on if the HAT comes back.
On a firmware in the loop a crash or a sanitizer report is no target fault but a failure of the case
that met it; the firmware is started again (plugin/firmware_findings.py).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import sys
import time
from typing import Any, Dict, List, Optional, Tuple

import pytest

from ...harness.errors import BrokenClause
from ...harness.targets.base import TargetError
from ..case_order import MARKER as TOGETHER_MARKER
from ..case_order import keep_together, seed_in_use
from ..hat_under_test import HatUnderTest
from ..target_fault import TargetFault, fault_line, first_line, is_target_fault
from ..tee import TeeTarget, tee
from ..trusted_clauses import MARKER as CLAUSE_MARKER
from ..verdict import FAIL, INFO, KNOWN, NOT_RUN, PASS, SKIP, TARGET_FAULT, UnknownBuild, Verdict
from .firmware_findings import PROPERTY as DEFECTS_PROPERTY
from .firmware_findings import FirmwareFindings
from .junit import Case, JUnitFile, failure_line
from .options import settle_output_paths
from .recovery import RecoveryFailed, ResetRecovery
from .run_outcome import banner, nothing_done, release_mismatch
from .summary import firmware_of, write_summary

DEFAULT_CASE_TIMEOUT = 120.0
# The exit statuses every command shares (docs/USING.md): 0 conforms, 1 conformance failures, 2 usage
# error, 3 target unreachable or faulted.
EXIT_OK, EXIT_FAILED, EXIT_TARGET = 0, 1, 3

_verdict_key = pytest.StashKey[Verdict]()
_not_run_key = pytest.StashKey[str]()          # why the case was not run
_call_failed_key = pytest.StashKey[bool]()
_reports_key = pytest.StashKey[List[Any]]()    # the firmware's reports met in this case, not yet judged


def pytest_configure(config: Any) -> None:
    settle_output_paths(config)
    config.addinivalue_line("markers", "req(*ids): requirement IDs (REQUIREMENTS.md or FW-...) a test checks")
    config.addinivalue_line("markers", "slow: takes more than a few seconds")
    config.addinivalue_line("markers", f"{CLAUSE_MARKER}(name): a clause the harness relies on, checked "
                                       "first (conformance/trusted_clauses.py)")
    config.addinivalue_line("markers", f"{TOGETHER_MARKER}(name): cases that share state, kept next to each "
                                       "other in a shuffled order (conformance/case_order.py)")
    if not hasattr(config, "workerinput"):
        run = SuiteRun(config)
        config.stash[_run_key] = run
        config.pluginmanager.register(run, "buildhat-conformance-run")


def target_url(config: Any) -> str:
    from ...plumbing.cli_options import expand_target

    speed = config.getoption("speed")
    return expand_target(config.getoption("target"), float(speed) if speed else None)


def requirement_ids(item: Any) -> List[str]:
    ids: List[str] = []
    for mark in item.iter_markers("req"):
        ids.extend(str(a) for a in mark.args)
    return ids


def transcript_name(nodeid: str) -> str:
    """A file name for a case's transcript, unique per case: the node id with unsafe
    characters replaced, plus a digest of the exact node id whenever that replacement (or the
    length limit) lost anything (`[vin;vin]` and `[vin ; vin]` must not share a file)."""
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", nodeid).strip("_")
    if safe == nodeid and len(safe) <= 180:
        return safe
    digest = hashlib.sha1(nodeid.encode("utf-8")).hexdigest()[:10]
    return f"{safe[:170]}-{digest}"


class SuiteRun:
    """State of one conformance run (a plugin object, so its hooks see everything)."""

    def __init__(self, config: Any):
        self.config = config
        self.url = target_url(config)
        self.transcripts = config.getoption("transcripts")
        self.hat: Optional[HatUnderTest] = None
        self.tee: Optional[TeeTarget] = None
        self.open_error: Optional[str] = None
        self.broken: Optional[BrokenClause] = None   # a Build HAT breaking a clause at open
        self.results: Dict[str, Tuple[str, List[str]]] = {}      # nodeid -> (verdict class, req ids)
        self.skip_reasons: Dict[str, str] = {}                   # nodeid -> why it was skipped
        self.has_control = False        # the target performs world actions (plug, ...)
        self.no_job: Optional[str] = None     # why the run could not do its job (exit 3)
        self.collected_ids: Dict[str, List[str]] = {}
        self._case: Dict[str, Case] = {}
        self._started: Dict[str, float] = {}
        self.max_target_faults = int(config.getoption("max_target_faults") or 0)
        self.faults_in_a_row = 0
        self.stopped: Optional[str] = None      # why the run stopped talking to the target
        self.target_faults: List[Tuple[str, str]] = []    # (nodeid, what the target did)
        self.recovery = ResetRecovery(config.getoption("image"), config.getoption("signature"))
        self.reset_due: Optional[str] = None    # why the next case begins with the run's one reset
        self.seed: Optional[int] = None       # the shuffled order's seed (conformance/case_order.py)
        self.junit = JUnitFile(config.getoption("conformance_junit"), "buildhat-conformance",
                               [("target", self.url)])
        self.firmware = FirmwareFindings()      # a firmware in the loop's own defects (sanitizers)

    # -- the shared session --------------------------------------------------------------
    def open(self) -> HatUnderTest:
        if self.hat is not None:
            return self.hat
        if self.broken is not None:
            raise CannotJudge(str(self.broken))
        if self.open_error:
            raise TargetFault("unreachable", self.open_error)
        from ...harness.session import Session
        from ...harness.targets import make_target
        from ...harness.transcript import TranscriptWriter
        from ...protocol.profiles import get_profile

        between = TranscriptWriter(os.path.join(self.transcripts, "_between-cases.jsonl"),
                                   {"target": self.url, "firmware": "unknown", "case": "between cases"})
        try:
            self.tee = tee(make_target(self.url), between=between)
            forced = self.config.getoption("firmware")
            profile = get_profile(forced) if forced else None
            session = Session(self.tee, transcript=None, profile=profile)
            session.open()
        except BrokenClause as exc:
            # A Build HAT that breaks a clause the session needs: that clause's case fails
            # (case_fixtures.py), every other case is not-run; nothing else can be judged.
            self.broken = exc
            self.junit.set_property("broken_clauses", f"{exc.requirement} failed at open: {exc.finding}")
            self._stop(str(exc))
            raise CannotJudge(str(exc)) from None
        except Exception as exc:  # the message says how to reach the target
            why = first_line(str(exc)) or type(exc).__name__
            self.open_error = why if self.url in why else f"cannot open target {self.url}: {why}"
            self.stopped = self.open_error
            raise TargetFault("unreachable", self.open_error) from exc
        self.hat = HatUnderTest(session, self.tee, self.url)
        self.has_control = bool(self.hat.can("plug"))
        p = self.hat.profile
        # --firmware judges as a release; the firmware property stays what the target runs.
        self.junit.set_property("firmware", session.version_string or p.version_string)
        if forced:
            self.junit.set_property("judged_as", f"{p.name} ({p.number}, --firmware)")
        self.junit.set_property("profile", self.hat.profile_label)
        if self.hat.profile_why:
            self.junit.set_property("profile_why", self.hat.profile_why)
        mismatch = release_mismatch(self.url, session.version_string, p) if forced else None
        if mismatch is not None:
            self.no_job = mismatch
            self._stop(mismatch)
            raise CannotJudge(mismatch)
        return self.hat

    def close(self) -> None:
        if self.hat is not None:
            try:
                self.hat.session.close()
            except Exception:  # noqa: BLE001 - closing a dead target must not mask the results
                pass
            self._firmware_coverage()
        if self.tee is not None and self.tee.between is not None:
            self.tee.between.close()

    def _firmware_coverage(self) -> None:
        """A ``sil:`` target built with coverage: the firmware's figure beside the JUnit file."""
        target = getattr(self.tee, "inner", None)
        measure = getattr(target, "firmware_coverage", None)
        if measure is None:
            return
        try:
            summary = measure()
        except TargetError as exc:
            print(f"\n{exc}", file=sys.stderr)
            return
        if summary is None:
            return
        path = os.path.join(os.path.dirname(os.path.abspath(self.junit.path)), "firmware-coverage.json")
        with open(path, "w", encoding="utf-8") as out:
            json.dump(summary.as_dict(), out, indent=1)
        self.junit.set_property("firmware_coverage", f"lines {summary.line_percent:.1f}%, "
                                                     f"branches {summary.branch_percent:.1f}%")
        reporter = self.config.pluginmanager.get_plugin("terminalreporter")
        for line in [""] + summary.text().splitlines():
            if reporter is not None:
                reporter.write_line(line)
            else:
                print(line, file=sys.stderr)

    # -- hooks -----------------------------------------------------------------------------
    @pytest.hookimpl(trylast=True)
    def pytest_collection_modifyitems(self, items: List[Any]) -> None:
        # Cases that share state stay together in a shuffled order (conformance/case_order.py); the
        # clauses the harness relies on are checked before anything relies on them.
        keep_together(items)
        self.seed = seed_in_use(self.config)
        if self.seed is not None:
            self.junit.set_property("random_order", str(self.seed))
        items[:] = sorted(items, key=lambda item: item.get_closest_marker(CLAUSE_MARKER) is None)
        for item in items:
            self.collected_ids[item.nodeid] = requirement_ids(item)
            if item.get_closest_marker("timeout") is None:
                item.add_marker(pytest.mark.timeout(DEFAULT_CASE_TIMEOUT))

    # -- a firmware in the loop's crashes and sanitizer reports (plugin/firmware_findings.py) ------
    def take_firmware_reports(self, item: Any) -> None:
        """The firmware's new reports, into this case (its transcript, the run's list)."""
        if self.tee is None:
            return
        found = self.firmware.take(self.tee, item.nodeid)
        if found:
            item.stash.setdefault(_reports_key, []).extend(found)
            self.junit.set_property(DEFECTS_PROPERTY, self.firmware.as_property())

    def after_case_firmware(self, item: Any) -> None:
        """At the end of a case: its reports taken, and a firmware that crashed started again (its
        start-up in this case's transcript); the next case's fence restores the set-up."""
        self.take_firmware_reports(item)
        target = FirmwareFindings.target_of(self.tee)
        if target is None or self.hat is None or not target.firmware_crashed:
            return
        from ...harness.errors import ExpectTimeout
        from .recovery import ANSWER_S

        assert self.tee is not None
        session = self.hat.session
        self.tee.revived()
        session.forget_failure()
        since = session.mark()
        try:
            session.reset(timeout=ANSWER_S)
        except (TargetError, ExpectTimeout) as exc:
            self.take_firmware_reports(item)
            self._stop(f"the firmware crashed in {item.nodeid} and did not answer when started again "
                       f"({first_line(str(exc))})")
            return
        self.hat.after_reset(since)

    def _judge_firmware_reports(self, item: Any, report: Any) -> bool:
        """Fail this phase of the case with the firmware's reports it met (not suppressed); True
        when it did. Reports met while setting up wait for the case itself."""
        self.take_firmware_reports(item)
        pending = item.stash.get(_reports_key, [])
        if not pending or (report.when == "setup" and not report.failed):
            return False
        item.stash[_reports_key] = []
        met = [r for r in pending if r.suppressed_by is None]
        if not met:
            return False
        # The first report met names the defect; a crash that followed it is said after it.
        fatal = next((r for r in met if r.fatal), None)
        message = met[0].first + (f" (then the firmware crashed: {fatal.first})"
                                  if fatal is not None and fatal is not met[0] else "")
        before = report.longreprtext if report.failed else ""
        report.outcome = "failed"
        report.longrepr = "\n\n".join([message] + [r.text for r in met]
                                       + ([f"(what the case saw)\n{before}"] if before else []))
        return True

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(self, item: Any, call: Any):
        outcome = yield
        report = outcome.get_result()
        exc = call.excinfo.value if call.excinfo is not None else None
        verdict = item.stash.get(_verdict_key, None)
        if self._judge_firmware_reports(item, report):
            # The firmware's own defect: a failure of this case, never a target fault.
            exc = FirmwareDefect(report.longreprtext)
        if report.when == "call" and verdict is not None and isinstance(exc, UnknownBuild):
            # The check needed a behaviour the releases around this unknown build differ on.
            verdict.inform(str(exc))
            report.outcome, report.longrepr, exc = "passed", None, None
        unreset = self.hat.setup_check.unreset if self.hat is not None else []
        if report.when == "call" and verdict is not None and report.failed and unreset \
                and not is_target_fault(exc) and not isinstance(exc, FirmwareDefect):
            # The set-up could not reset it (conformance/setup_check.py): the failure may be the
            # last case's leftovers, not this one's finding.
            verdict.inform(f"not reset between cases on this build: {', '.join(unreset)}; failed: "
                           f"{first_line(str(exc))}")
            report.outcome, report.longrepr, exc = "passed", None, None
        if report.failed and not is_target_fault(exc) and self.hat is not None and \
                not isinstance(exc, FirmwareDefect):
            # A check that failed while the target flooded the link or spewed garbage failed
            # because of the link: a target fault, not a protocol failure.
            exc = self.hat.babble() or exc
        if report.failed and is_target_fault(exc):
            assert exc is not None
            report.user_properties.append(("target_fault", fault_line(exc)))
        if report.when == "call":
            item.stash[_call_failed_key] = bool(report.failed)
        not_run = item.stash.get(_not_run_key, None)
        if not_run is not None and report.skipped:
            report.user_properties.append(("not_run", not_run))
        if report.when != "call" or verdict is None:
            return
        if report.passed:
            cls = verdict.verdict_class
        elif report.skipped:
            cls = SKIP
        else:
            cls = TARGET_FAULT if is_target_fault(exc) else FAIL
        report.user_properties.append(("verdict", cls))
        self._learn_clause(item, cls)
        if verdict.known:
            report.user_properties.append(("deviations", ",".join(k for k, _ in verdict.known)))
            report.sections.append(("known deviations", "\n".join(f"{k}: {s}" for k, s in verdict.known)))
        if verdict.notes:
            report.user_properties.append(("notes", " | ".join(verdict.notes)))

    def _learn_clause(self, item: Any, cls: str) -> None:
        """A case of a clause the harness relies on tells the link whether to trust it."""
        mark = item.get_closest_marker(CLAUSE_MARKER)
        if mark is None or self.hat is None:
            return
        clauses = self.hat.clauses
        if cls == FAIL:
            clauses.broke(str(mark.args[0]), item.nodeid)
            self.junit.set_property("broken_clauses", " | ".join(clauses.broken()))
        elif cls in (PASS, KNOWN, INFO):
            clauses.held(str(mark.args[0]))

    def pytest_report_teststatus(self, report: Any, config: Any):
        props = dict(report.user_properties)
        if report.failed and "target_fault" in props:
            return "target-fault", "T", ("TARGET-FAULT", {"red": True})
        if report.skipped and "not_run" in props:
            return "not-run", "N", ("NOT RUN", {"yellow": True})
        if report.when == "call" and report.passed:
            cls = props.get("verdict")
            if cls == KNOWN:
                return "known deviation", "K", ("KNOWN DEVIATION", {"yellow": True})
            if cls == INFO:
                return "informational", "I", ("INFORMATIONAL", {"cyan": True})
        return None

    def pytest_runtest_logstart(self, nodeid: str, location: Any) -> None:
        self._started[nodeid] = time.monotonic()

    def pytest_runtest_logreport(self, report: Any) -> None:
        nodeid = report.nodeid
        case = self._case.get(nodeid)
        if case is None:
            module, _, name = nodeid.partition("::")
            case = Case(classname=module.replace("/", ".").removesuffix(".py"), name=name or nodeid)
            self._case[nodeid] = case
        props = dict(case.properties)
        for k, v in report.user_properties:
            props[k] = str(v)
        case.properties = list(props.items())
        if report.failed and "target_fault" in props and case.outcome != "error":
            # What the target did, in one line; the traceback stays in the details.
            case.outcome, case.message = "error", props["target_fault"]
            case.details = report.longreprtext
        elif report.failed and case.outcome not in ("failed", "error"):
            case.outcome = "failed" if report.when == "call" else "error"
            case.message = failure_line(report)
            case.details = report.longreprtext
        elif report.skipped and case.outcome == "passed":
            case.outcome = "skipped"
            reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
            case.message = case.details = str(reason).removeprefix("Skipped: ")
        if report.when == "teardown":
            self._finish(nodeid, case)

    def _finish(self, nodeid: str, case: Case) -> None:
        case.time = time.monotonic() - self._started.get(nodeid, time.monotonic())
        props = dict(case.properties)
        if "target_fault" in props:
            cls = TARGET_FAULT
        elif "not_run" in props:
            cls = NOT_RUN
        else:
            cls = {"failed": FAIL, "error": FAIL, "skipped": SKIP}.get(case.outcome) \
                or props.get("verdict", PASS)
        props["verdict"] = cls
        case.properties = list(props.items())
        self.junit.add(case)
        self.results[nodeid] = (cls, self.collected_ids.get(nodeid, []))
        if cls == SKIP:
            self.skip_reasons[nodeid] = case.message or ""
        del self._case[nodeid]
        self._count_fault(nodeid, cls, props.get("target_fault", ""))

    def _count_fault(self, nodeid: str, cls: str, what: str) -> None:
        """N target faults in a row: stop talking to the target (the rest is not-run)."""
        if cls == NOT_RUN:
            return
        if cls != TARGET_FAULT:
            self.faults_in_a_row = 0
            return
        self.target_faults.append((nodeid, what))
        self.faults_in_a_row += 1
        dead = self.tee is not None and self.tee.dead
        if self.stopped is None and (dead or self.max_target_faults and
                                     self.faults_in_a_row >= self.max_target_faults):
            why = "the target went away" if dead else f"{self.faults_in_a_row} target faults in a row"
            why = f"{why}; the last: {what}"
            no_reset = self.recovery.why_not(self.tee) if self.tee is not None and self.hat is not None \
                else "the target is closed"
            if no_reset is None:
                self.reset_due = why        # the next case begins with the run's one reset
                return
            self._stop(why if self.recovery.outcome is None else f"{why}; {no_reset}")

    def _stop(self, why: str) -> None:
        self.stopped = why
        self.junit.set_property("stopped", self.stopped)
        if self.hat is not None:
            self._close_quietly()

    def recover(self) -> None:
        """The run's one reset of a HAT that stopped answering (conformance/plugin/recovery.py), its
        bytes in their own transcript; the run goes on if the HAT comes back, else it stops."""
        from ...harness.transcript import TranscriptWriter

        due, self.reset_due = self.reset_due, None
        assert self.hat is not None and self.tee is not None and due is not None
        session = self.hat.session
        writer = TranscriptWriter(os.path.join(self.transcripts, "_reset.jsonl"),
                                  {"target": self.url, "firmware": firmware_of(self.hat), "case": "reset"})
        self.tee.switch(writer)
        since = session.mark()
        recovered = False
        try:
            self.recovery.attempt(session)
            self.hat.after_reset(since)
            self.faults_in_a_row = 0
            recovered = True
        except RecoveryFailed:
            pass        # the outcome says why, in one line
        finally:
            self.tee.switch(None)
            writer.close()
        outcome = self.recovery.outcome or "reset the HAT once"
        self.junit.set_property("reset", f"{outcome} (after {due})")
        if not recovered:
            self._stop(f"{due}; {outcome}")

    def _close_quietly(self) -> None:
        # Stop talking to the target now: a hung HAT must not be written to (or waited for) again.
        try:
            self.close()
        finally:
            self.hat = None
            self.open_error = self.open_error or self.stopped

    def pytest_sessionfinish(self, session: Any, exitstatus: Any) -> None:
        self.close()
        idle = nothing_done(self.results, self.skip_reasons, self.has_control)
        if idle is not None and self.no_job is None:
            self.no_job = idle
            self.junit.set_property("stopped", idle)
        if self.firmware.defects:
            self.junit.set_property(DEFECTS_PROPERTY, self.firmware.as_property())
        if self.results:    # the run's verdict in words, skips counted (for reports that show it)
            self.junit.set_property("banner", banner(self.results, self.skip_reasons, self.has_control))
        self.junit.write()
        if int(exitstatus) in (EXIT_OK, EXIT_FAILED):
            session.exitstatus = self.exit_status()

    def exit_status(self) -> int:
        """The agreed exit statuses: 1 if any case failed (a finding about the protocol counts
        even when the target later faulted), else 3 if the target faulted or was not reached or
        the run could do nothing (every case skipped, the wrong release), else 0."""
        verdicts = {cls for cls, _ in self.results.values()}
        if FAIL in verdicts:
            return EXIT_FAILED
        if verdicts & {TARGET_FAULT, NOT_RUN} or self.stopped or self.no_job:
            return EXIT_TARGET
        return EXIT_OK

    def pytest_terminal_summary(self, terminalreporter: Any) -> None:
        if self.results:
            write_summary(terminalreporter, self)


class FirmwareDefect(Exception):
    """A firmware in the loop crashed or broke a sanitizer's rule in this case: a failure."""


class CannotJudge(Exception):
    """The run cannot judge this target (one line: why); every case is not-run."""


_run_key = pytest.StashKey[SuiteRun]()

"""A build between two known releases (1635608703: 2021-10-30, between R1 of 2021-08-28 and R2 of
2021-11-05) is judged by the document; where R1 and R2 are known to differ (deviations.json,
profiles.json features from FIRMWARE-FACTS), the case is informational, never a failure.

The builds are the in-process emulator of one release reporting the unknown version
(``inprocess:R2?version=1635608703``): an R2-like build and an R1-like one.
"""
from __future__ import annotations

import tempfile
from concurrent.futures import ThreadPoolExecutor

import pytest
from mutants.suite_run import run_suite

from buildhat_conformance.conformance.verdict import INFO, KNOWN, Verdict
from buildhat_conformance.protocol.profiles import get_profile, neighbours, undecided_features

pytestmark = pytest.mark.timeout(300)

BUILD = 1635608703
#: Cases that tell R1 from R2 (FACTS §5), one where they agree (§6.2), and passive ID 1 for contrast.
CASES = ("test_passive_device_is_listed_by_its_id and (5 or 1) or test_unplug_says_disconnected or "
         "test_passive_device_connect_message or test_button_events or test_selonce_variable_reports_once")


def test_a_build_between_releases_has_both_as_neighbours():
    r1, r2 = get_profile("R1"), get_profile("R2")
    assert neighbours(BUILD) == (r1, r2)
    assert neighbours(r1.number) is None                     # a release is itself
    assert neighbours(get_profile("R7").number + 1) is None  # after the last: nearest earlier as before
    differ = undecided_features(r1, r2)
    assert {"passive_port_reset_each_scan", "button_events", "disconnected_line"} <= differ
    assert "pid_numbers" not in differ and "document_language" not in differ


def test_verdict_where_the_neighbours_differ_is_informational_and_where_they_agree_unchanged():
    v = Verdict("R1", ("R1", "R2"))
    v.document(False, key="NO-DISCONNECTED-LINE", firmware_ok=True, seen="no line")   # R1 only
    assert v.verdict_class == INFO and "behaviour of R1 or R2" in v.notes[-1]
    with pytest.raises(pytest.fail.Exception):            # neither the document nor R1's behaviour
        Verdict("R1", ("R1", "R2")).document(False, key="NO-DISCONNECTED-LINE", firmware_ok=False)
    agree = Verdict("R1", ("R1", "R2"))                   # both R1 and R2 repeat selonce (FACTS §6.2)
    agree.document(False, key="SELONCE-VAR-REPEATS", firmware_ok=True)
    assert agree.verdict_class == KNOWN
    with pytest.raises(pytest.fail.Exception):            # neither R1 nor R2 rejects the 10-number pid
        Verdict("R1", ("R1", "R2")).document(False, key="PID-DOC-ARGS-REJECTED", firmware_ok=True)


#: A build between R5 and R6, whose command tables differ (R6 dropped bias, FACTS §2), behaving as R6.
BUILD_R5_R6 = "1672000000%202022-12-25T20:26:40%2B00:00"
TABLE_CASES = ("test_help_prints_the_synopsis_of_this_release or "
               "(test_shortest_resolving_prefix_runs_the_command and (bias or pwmparams))")


def _run(target: str, keyword: str = CASES):
    with tempfile.TemporaryDirectory() as tmp:
        return run_suite(tmp, target, keyword=keyword, timeout=240)


def test_unknown_builds_are_never_failed_for_what_a_neighbour_does():
    # (R1 itself gets these as known deviations: tests/conformance/test_deviations.py checks that.)
    with ThreadPoolExecutor(max_workers=3) as pool:      # child pytests, mostly start-up time
        runs = [pool.submit(_run, f"inprocess:R2?version={BUILD}"),
                pool.submit(_run, f"inprocess:R1?version={BUILD}"),
                pool.submit(_run, f"inprocess:R6?version={BUILD_R5_R6}", TABLE_CASES)]
        r2_like, r1_like, r6_like = (run.result() for run in runs)
    assert len(r2_like) >= 7 and set(r2_like) == set(r1_like)
    for results in (r2_like, r1_like):
        failed = {n: r.message.splitlines()[0] for n, r in results.items() if r.verdict == "fail"}
        assert not failed, failed
    # The case: R1 cannot list a button (FACTS §5), this build can: judged by the document.
    assert r2_like["test_passive_device_is_listed_by_its_id[5]"].verdict == "pass"
    # A build that behaves like R1 there is not failed either: R1 or R2, unknown.
    for name in ("test_passive_device_is_listed_by_its_id[5]", "test_unplug_says_disconnected[active]",
                 "test_passive_device_connect_message"):
        got = r1_like[name]
        assert got.verdict == "informational", (name, got.verdict, got.message)
        assert "behaviour of R1 or R2" in got.properties.get("notes", ""), got.properties
    # Checks that rest on a behaviour R1 and R2 differ on are informational for either build.
    for results in (r2_like, r1_like):
        assert results["test_button_events"].verdict == "informational"
        assert "button_events" in results["test_button_events"].properties["notes"]
    # Where R1 and R2 agree (selonce repeats, §6.2), the deviation stays a known deviation.
    assert r2_like["test_selonce_variable_reports_once"].verdict == "known deviation"
    # Between R5 and R6 the command tables differ: checks that rest on the table are informational
    # (driven with R5's table, an R6-like build would otherwise fail `help` and every bias prefix).
    assert len(r6_like) >= 4, sorted(r6_like)
    failed = {n: r.message.splitlines()[0] for n, r in r6_like.items() if r.verdict == "fail"}
    assert not failed, failed
    for name in ("test_help_prints_the_synopsis_of_this_release[help]",
                 "test_shortest_resolving_prefix_runs_the_command[bias]"):
        assert r6_like[name].verdict == "informational", (name, r6_like[name].verdict)
        assert "behaviour of R5 or R6" in r6_like[name].properties.get("notes", "")

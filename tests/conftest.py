import collections
import functools
import os
import pathlib
import re
import sys
from typing import Any

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))     # the helpers beside the tests (shared_material, ...)

from shared_material import SKIP_PREFIX  # noqa: E402

# `fuzz --jobs auto` (the default) forks a worker per CPU; the tests already share the machine's
# cores among pytest-xdist's workers, so their campaigns take one unless a test says otherwise
# (tests/fuzz/test_jobs.py tests the default itself, without this).
os.environ.setdefault("BUILDHAT_CONFORMANCE_JOBS", "1")


def pytest_terminal_summary(terminalreporter: Any) -> None:
    """Say why tests skipped, one line per reason: ``3 skipped: no ../shared (the facts document
    itself)`` (a user's clone has no ``../shared``), ``2 skipped: chromium is not installed ...``."""
    why: collections.Counter = collections.Counter()
    for report in terminalreporter.stats.get("skipped", []):
        longrepr = getattr(report, "longrepr", None)
        reason = longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3 else "(no reason given)"
        reason = reason.removeprefix("Skipped: ")
        if reason.startswith(SKIP_PREFIX):
            why[reason.split(":", 1)[0] + " (set BUILDHAT_SHARED to run them)"] += 1
        else:
            why[reason.split(";", 1)[0]] += 1
    for reason, n in sorted(why.items()):
        terminalreporter.write_line(f"{n} skipped: {reason}")


# Tests marked ``network`` install from PyPI, and a failed install fails them. A run without the
# network says so on purpose (BUILDHAT_TESTS_OFFLINE=1, e.g. set by an offline CI job) and they skip
# with that reason; an install failure never turns into a skip.
OFFLINE_ENV = "BUILDHAT_TESTS_OFFLINE"


# The long tier (`make test-long`): tests that run the whole suite, a campaign or a history several
# times on a firmware in the loop, 30-100 s each on this project's 2-core machines. `make test` (CI)
# leaves them out so it stays well under ten minutes; each is listed here, by file or by test, so one
# place says what the quick tier does not run. Run them before a release and after changing what they
# cover (sil/, conformance/comparison.py, conformance/case_order.py, fuzz crash handling).
LONG_TESTS = (
    "end_to_end/test_sil_mutate_shards.py::test_two_shards_merged_are_the_whole_campaign",
    "end_to_end/test_sil_history.py::",
    "end_to_end/test_run_baseline.py::test_a_changed_help_line_lists_exactly_the_cases_that_print_it",
    "end_to_end/test_run_baseline.py::test_a_tree_against_itself_lists_nothing",
    "end_to_end/test_conformance_case_order.py::test_two_shuffled_orders_give_the_suite_s_own_verdicts",
    "end_to_end/test_sil_crashes.py::test_r7_sanitized_gives_the_plain_verdicts",
    "end_to_end/test_sil_crashes.py::test_fuzzing_the_sanitized_r7_keeps_its_findings",
    # the plain build's variant stays in `make test`; the sanitized build alone costs a CI minute
    "end_to_end/test_sil_crashes.py::test_a_planted_null_store_fails_its_case_and_the_run_goes_on[sanitized]",
    # CI time (issue #36's session): each of these holds a worker for 40-50 s, mostly wall-clock waits
    "end_to_end/test_conformance_virtual_time.py::test_virtual_time_verdicts_equal_the_wall_clock_run",
    "end_to_end/test_lab_labgrid_locks.py::test_a_second_run_on_a_held_place_says_so_or_waits_for_it",
    "end_to_end/test_sil_mutate.py::test_a_build_hat_breaking_a_clause_at_open_is_killed_not_refused",
    "end_to_end/test_firmware_example_workflow.py::test_the_steps_run_on_a_tree_with_a_stray_test_program",
    "end_to_end/test_sil_bisect.py::test_bisect_skips_a_commit_that_does_not_build",
)


def _is_long(item: pytest.Item) -> bool:
    where = item.nodeid.replace("\\", "/")
    return any(f"tests/{name}" in where or where.startswith(name) for name in LONG_TESTS)


def pytest_collection_modifyitems(config: pytest.Config, items: list) -> None:
    for item in items:
        if _is_long(item):
            item.add_marker(pytest.mark.long)
    if os.environ.get(OFFLINE_ENV, "") not in ("", "0"):
        skip = pytest.mark.skip(reason=f"offline run ({OFFLINE_ENV}=1): needs the network")
        for item in items:
            if item.get_closest_marker("network"):
                item.add_marker(skip)


# Under ``make test`` (pytest-xdist, ``--dist loadgroup``): a module that defines a module-scoped
# fixture (a whole suite run, a library matrix, a browser check) runs on one worker, so the fixture is
# computed once, not once per worker. Its own scheduler rather than xdist_group marks: xdist 3.8 puts
# the group into ``item._nodeid``, which pytest 9 no longer reads, so the marks group nothing.
_MODULE_FIXTURE = re.compile(r"@pytest\.fixture\(\s*scope=[\"']module[\"']")


@functools.cache
def _shares_a_module_fixture(path: str) -> bool:
    try:
        return bool(_MODULE_FIXTURE.search((REPO / path).read_text(encoding="utf-8")))
    except OSError:
        return False


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadGroupScheduling

    class ModuleFixtureScheduling(LoadGroupScheduling):
        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            return path if _shares_a_module_fixture(path) else super()._split_scope(nodeid)

    return ModuleFixtureScheduling(config, log)

"""sil/sanitizer_reports.py: a firmware's stderr read as its reports, and a suppressions file.

The reports are real: a small C program of the test's own, built with the sanitizers recovering
(as sil/build.py builds a firmware) and run with sil/process.py's options, breaks three rules and
then dies of a wild store. Each report must come out once, in order, with its kind, file and
line; the last one fatal."""
import os
import shutil
import subprocess

import pytest

from buildhat_conformance.sil.sanitizer_reports import (
    Suppressions,
    SuppressionsError,
    crash_report,
    split_reports,
)

CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")

PROGRAM = r"""
#include <stdio.h>
unsigned char table[128];
volatile int at = 128, by = 24, big = 128;
static float *volatile nowhere;
int shifted(void) { return big << by; }                 /* line 6 */
int looked_up(void) { return table[at]; }               /* line 7 */
int main(void) {
    int a = shifted();
    int b = looked_up();
    printf("%d %d\n", a, b);
    *(volatile float *)nowhere = 1.0f;                  /* line 12 */
    return 0;
}
"""


@pytest.fixture(scope="module")
def stderr_text(tmp_path_factory) -> str:
    folder = tmp_path_factory.mktemp("ubsan")
    src = folder / "rules.c"
    src.write_text(PROGRAM)
    exe = folder / "rules"
    assert CC is not None
    subprocess.run([CC, "-g", "-O1", "-fsanitize=address,undefined", "-fsanitize-recover=all", str(src),
                    "-o", str(exe)], check=True)
    env = dict(os.environ, ASAN_OPTIONS="abort_on_error=0:halt_on_error=0:exitcode=86:detect_leaks=0",
               UBSAN_OPTIONS="halt_on_error=0:exitcode=86:print_stacktrace=1")
    done = subprocess.run([str(exe)], capture_output=True, text=True, env=env)
    assert done.returncode == 86, done.stderr[-2000:]
    return done.stderr


def test_each_report_once_in_order_with_its_place(stderr_text):
    reports, _other = split_reports(stderr_text)
    keys = [r.key for r in reports]
    assert keys[0] == ("shift-base", "rules.c", 6)
    assert ("bounds", "rules.c", 7) in keys and ("global-buffer-overflow", "rules.c", 7) in keys
    assert keys[-1] == ("SEGV", "rules.c", 12)
    assert len(keys) == len(set(keys)), keys
    assert reports[0].first.startswith("UndefinedBehaviorSanitizer: rules.c:6:")
    assert "left shift of 128 by 24 places" in reports[0].first
    assert reports[0].functions[0] == "shifted"
    assert [r.fatal for r in reports] == [False] * (len(reports) - 1) + [True]
    assert "Shadow bytes" in next(r.text for r in reports if r.kind == "global-buffer-overflow")


def test_suppressions_match_as_the_sanitizers_do(stderr_text, tmp_path):
    reports, _other = split_reports(stderr_text)
    rules = tmp_path / "supp.txt"
    rules.write_text("# acknowledged\nshift-base:^shifted$\nbounds:rules.c\nglobal-buffer-overflow:looked_*\n"
                     "null:no_such_function\n")
    supp = Suppressions.read(str(rules))
    covered = {r.kind: supp.match(r) for r in reports}
    assert covered["shift-base"] == "shift-base:^shifted$"
    assert covered["bounds"] == "bounds:rules.c"
    assert covered["global-buffer-overflow"] == "global-buffer-overflow:looked_*"
    assert covered["SEGV"] is None and covered.get("null") is None
    # a kind's rule does not cover another kind at the same place
    assert Suppressions([("bounds", "shifted")]).match(reports[0]) is None


def test_a_bad_suppressions_file_is_one_line(tmp_path):
    with pytest.raises(SuppressionsError, match="no-such-file"):
        Suppressions.read(str(tmp_path / "no-such-file"))
    bad = tmp_path / "bad.txt"
    bad.write_text("shift-base\n")
    with pytest.raises(SuppressionsError, match=r"line 1: 'shift-base' is not 'kind:pattern'"):
        Suppressions.read(str(bad))


def test_a_crash_no_sanitizer_explained_is_named_by_its_signal():
    report = crash_report("SIGSEGV", "sil: the firmware was killed by SIGSEGV")
    assert report.key == ("SIGSEGV", "", 0) and report.fatal
    assert report.first == "the firmware crashed (SIGSEGV)"
    # A program that said what happened (the rp2040 runner's stopped core): its line follows.
    said = crash_report("SIGABRT", "rp2040: the core stopped at ...", "rp2040: the core stopped at ...")
    assert said.first == "the firmware crashed (SIGABRT): rp2040: the core stopped at ..."

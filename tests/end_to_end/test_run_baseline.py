"""`run --baseline` through the user's command on the firmware in the loop: a copy of the R7 tree
whose help text has one line changed, against the tree itself. What must be listed is found here
from the baseline's own transcripts (the cases in which the HAT printed the line that changed), not
from the comparison under test."""
import json
import pathlib
import re
import xml.etree.ElementTree as ET

import pytest
from junit_props import properties
from sil_support import cli, copy_tree, firmware_tree, plant

pytestmark = pytest.mark.timeout(1200)

OLD, NEW = "report main power input voltage", "report main power input volts!!"


def _changed_copy(tmp_path):
    copy = copy_tree(tmp_path / "changed")
    plant(copy, "command.c", OLD, NEW)
    return copy


def _cases_that_printed(junit: pathlib.Path, text: str):
    """The cases (module::case[param]) whose transcript has a HAT line containing ``text``."""
    out = set()
    for case in ET.parse(junit).getroot().iter("testcase"):
        path = properties(case).get("transcript")
        if not path:
            continue
        for line in pathlib.Path(path).read_text().splitlines():
            entry = json.loads(line)
            if entry.get("dir") == "hat" and text in str(entry.get("line", entry.get("partial", ""))):
                out.add(f"{case.get('classname')}::{case.get('name')}")
                break
    return out


def _listed(stdout: str):
    """(tag, case) of each case the closing lines list."""
    found = re.finditer(r"^  (changed|intended|UNEXPECTED): (\S+)", stdout, re.M)
    return [(m.group(1), m.group(2)) for m in found]


@pytest.mark.slow
def test_a_changed_help_line_lists_exactly_the_cases_that_print_it(tmp_path):
    expect = tmp_path / "expect.txt"
    expect.write_text("# the help text's vin line changed\n*[help]\n*[?]\n\n"
                      "test_events::test_stall_line_only_past_2_ms   # prints help to fill the link\n")
    junit = tmp_path / "run" / "junit.xml"
    done = cli("run", "-t", f"sil:{_changed_copy(tmp_path)}", "--baseline", f"sil:{firmware_tree()}",
               "--expect-changes", str(expect), "--junit", str(junit), cache=tmp_path / "cache")
    printed = _cases_that_printed(junit.parent / "baseline" / "reference" / "junit.xml", OLD)
    listed = _listed(done.stdout)
    assert printed and {case for _tag, case in listed} == printed, done.stdout[-4000:]
    assert all(tag == "intended" for tag, _case in listed), done.stdout[-4000:]
    # the help cases fail against R7's help text, so the run's own exit status is 1 either way:
    # the comparison's verdict is what the closing line says
    assert done.returncode == 1 and f"{len(printed)} case(s) whose HAT output differs, 0 of them not in" \
        in done.stdout
    # each listed case's first differing lines, in the terminal, the JUnit file and the page
    assert f"      target:   '  vin                   : {NEW}'" in done.stdout
    cases = {f"{c.get('classname')}::{c.get('name')}": properties(c) for c in ET.parse(junit).getroot().iter(
        "testcase")}
    marked = {c for c, p in cases.items() if p.get("baseline.difference")}
    assert marked == printed
    assert all(cases[c]["baseline.difference"] == "intended" and NEW in cases[c]["baseline.target_line"]
               and OLD in cases[c]["baseline.baseline_line"] for c in printed)
    page = (junit.parent / "index.html").read_text()
    head = page[:page.index("id=failures")] if "id=failures" in page else page
    assert "Compared with the baseline" in head and NEW in head


@pytest.mark.slow
def test_a_tree_against_itself_lists_nothing(tmp_path):
    tree = f"sil:{firmware_tree()}"
    junit = tmp_path / "run" / "junit.xml"
    done = cli("run", "-t", tree, "--baseline", tree, "--expect-changes", "/dev/null", "--junit", str(junit),
               cache=tmp_path / "cache")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "0 case(s) whose HAT output differs" in done.stdout and not _listed(done.stdout)


@pytest.mark.slow
def test_a_difference_outside_expect_changes_fails_the_run(tmp_path):
    """Only the help cases of test_commands are meant to change: those of test_link and
    test_abbreviation are not, and fail the run, listed as such."""
    expect = tmp_path / "expect.txt"
    expect.write_text("test_commands::*\n")
    done = cli("run", "-t", f"sil:{_changed_copy(tmp_path)}", "--baseline", f"sil:{firmware_tree()}",
               "-k", "test_output_is_plain_text_lines or test_junk_after", "--expect-changes", str(expect),
               "--junit", str(tmp_path / "run" / "junit.xml"), cache=tmp_path / "cache")
    listed = dict((case, tag) for tag, case in _listed(done.stdout))
    assert listed == {"test_commands::test_junk_after_a_command_that_cannot_fail[help]": "intended",
                      "test_link::test_output_is_plain_text_lines[help]": "UNEXPECTED"}, done.stdout[-3000:]
    assert done.returncode == 1, done.stdout[-3000:]


@pytest.mark.parametrize("text,says", [
    ("test_a::one two\n", "2: 'test_a::one two'"),     # line 2 after a comment: the line is named
    ("a::b::c\n", "1: 'a::b::c': one '::' at most"),
    ("*\n", "'*' alone"),
    ("test_a[x\n", "[...] at its end"),
])
def test_a_bad_expect_changes_line_is_one_line_exit_2(tmp_path, text, says):
    expect = tmp_path / "expect.txt"
    expect.write_text(("# comment\n" if text.startswith("test_a::one") else "") + text)
    done = cli("run", "-t", "emulator", "--baseline", "emulator", "--expect-changes", str(expect),
               "--junit", str(tmp_path / "run" / "junit.xml"), cache=tmp_path / "cache")
    assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and f"--expect-changes {expect}:" in done.stderr
    assert says in done.stderr, done.stderr
    assert not (tmp_path / "run").exists()


def test_expect_changes_without_a_baseline_is_a_usage_error(tmp_path):
    done = cli("run", "-t", "emulator", "--expect-changes", "/dev/null", cache=tmp_path / "cache")
    assert done.returncode == 2 and "--expect-changes needs --baseline" in done.stderr, done.stderr


def test_a_baseline_that_cannot_run_is_one_line_naming_it(tmp_path):
    done = cli("run", "-t", "emulator", "--baseline", f"sil:{tmp_path / 'nope'}",
               "--junit", str(tmp_path / "run" / "junit.xml"), cache=tmp_path / "cache")
    assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
    assert done.stderr.strip().startswith("buildhat-conformance run: --baseline: sil: ")
    assert len(done.stderr.strip().splitlines()) == 1 and not (tmp_path / "run").exists()


def test_two_emulators_of_the_same_release_differ_in_nothing(tmp_path):
    """Any two targets: the emulator against itself (a second run as its only control)."""
    junit = tmp_path / "run" / "junit.xml"
    done = cli("run", "-t", "inprocess:R7", "--baseline", "inprocess:R7", "-k", "help or version",
               "--expect-changes", "/dev/null", "--junit", str(junit), cache=tmp_path / "cache")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "(2 run(s) of it): 0 case(s) whose HAT output differs" in done.stdout
    assert sorted(p.name for p in (junit.parent / "baseline").iterdir()) == ["again", "reference"]

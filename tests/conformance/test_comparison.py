"""conformance/comparison.py: when one case's HAT lines in two builds count as changed, the
expect-changes file, and what the JUnit file and the page get (the runs themselves:
tests/end_to_end/test_run_baseline.py)."""
import json
import xml.etree.ElementTree as ET

import pytest

from buildhat_conformance.conformance.baseline_runs import control_names
from buildhat_conformance.conformance.case_output import first_difference
from buildhat_conformance.conformance.comparison import (
    annotate_junit,
    compare_runs,
    judge_case,
    read_expect_changes,
)
from buildhat_conformance.plumbing.cli_options import UsageError

HELP = ["Commands available:", "  vin                   : report main power input voltage"]


def test_the_same_lines_or_a_report_elsewhere_among_the_answers_are_the_same():
    assert judge_case(HELP, [HELP]) == "same"
    assert judge_case(["P0M3: +96"] + HELP, [HELP + ["P0M3: +96"]]) == "same"


def test_a_changed_answer_is_changed_and_a_changed_report_is_timing():
    changed = HELP[:1] + ["  vin                   : report main power input volts!!"]
    assert judge_case(changed, [HELP, HELP]) == "changed"
    # what a motor's sample reads, or one report more, moves with the host's pacing (fb-async)
    assert judge_case(HELP + ["P0M3: +96"], [HELP + ["P0M3: +97"]]) == "timing"
    assert judge_case(HELP + ["P0M3: +96", "P0M3: +97"], [HELP + ["P0M3: +97"]]) == "timing"


def test_answers_the_baseline_itself_does_not_agree_on_count_only_by_new_text():
    glued = ["P0>versP0: pv=98.0000 sp=0.00000", "ok"]
    runs = [glued, ["P0>version", "ok"]]
    assert judge_case(["P0>versP0: pv=97.0000 sp=0.00000", "ok"], runs) == "timing"   # numbers aside
    assert judge_case(["P0>version", "not ok"], runs) == "changed"     # a line no baseline run sent
    assert judge_case(["P0>version"], runs) == "changed"               # one every baseline run sent


def test_first_difference_is_each_sides_first_differing_answer():
    assert first_difference(["a", "P0M3: +1", "b"], ["a", "c"]) == ("b", "c")
    assert first_difference(["a"], ["a", "c"]) == ("(none)", "c")
    assert first_difference(["a", "P0M3: +1"], ["a", "P0M3: +2"]) == ("P0M3: +1", "P0M3: +2")


def test_expect_changes_patterns(tmp_path):
    path = tmp_path / "expect.txt"
    path.write_text("# intended\n\ntest_commands::test_help[*]   # the help text\n*[?]\n")
    found = read_expect_changes(str(path))
    assert [(e.pattern, e.line) for e in found] == [("test_commands::test_help[*]", 3), ("*[?]", 4)]
    assert found[0].matches("test_commands::test_help[help]")
    assert not found[0].matches("test_link::test_help[x]")
    assert found[1].matches("test_abbreviation::test_prefix[?]") and not found[1].matches("test_a::b[help]")


@pytest.mark.parametrize("text,says", [("a b\n", ":1: 'a b': a case id has no spaces"),
                                       ("x\n::y\n", ":2: '::y': '::' needs a module"),
                                       ("**\n", "'*' alone")])
def test_a_bad_line_names_the_file_and_the_line(tmp_path, text, says):
    path = tmp_path / "expect.txt"
    path.write_text(text)
    with pytest.raises(UsageError, match=f"--expect-changes {path}"):
        read_expect_changes(str(path))
    try:
        read_expect_changes(str(path))
    except UsageError as exc:
        assert says in str(exc) and "\n" not in str(exc)


def test_a_missing_file_is_one_line(tmp_path):
    with pytest.raises(UsageError, match="no such file"):
        read_expect_changes(str(tmp_path / "nope"))


def test_phase_controls_only_for_the_firmware_in_the_loop():
    assert [n for n, _ns in control_names("emulator:R7")] == ["reference", "again"]
    assert [ns for _n, ns in control_names("sil:/t")][:2] == [0, 0] and len(control_names("sil:/t")) == 4


def _run(folder, cases):
    """A JUnit file and transcripts as the suite writes them: cases {name: HAT lines}."""
    folder.mkdir(parents=True)
    suite = ET.Element("testsuite", name="conformance")
    ET.SubElement(suite, "properties")
    for name, lines in cases.items():
        transcript = folder / f"{name}.jsonl"
        entries = [json.dumps({"t": 0, "dir": "hat", "line": line}) for line in lines]
        transcript.write_text("".join(e + "\n" for e in entries))
        case = ET.SubElement(suite, "testcase", classname="test_m", name=name)
        props = ET.SubElement(case, "properties")
        ET.SubElement(props, "property", name="verdict", value="pass")
        ET.SubElement(props, "property", name="transcript", value=str(transcript))
    root = ET.Element("testsuites")
    root.append(suite)
    path = folder / "junit.xml"
    ET.ElementTree(root).write(path)
    return path


def test_the_comparison_goes_into_the_junit_file_and_the_first_screen(tmp_path):
    from buildhat_conformance.conformance.report.html_baseline import baseline_section
    from buildhat_conformance.conformance.report.junit import read_junit

    new = HELP[:1] + ["  vin                   : report main power input volts!!"]
    target = _run(tmp_path / "t", {"help": new, "list": ["P0: no device detected"], "data": ["P0M3: +1"]})
    ref = _run(tmp_path / "b", {"help": HELP, "list": ["P0: no device detected"], "data": ["P0M3: +2"]})
    again = _run(tmp_path / "a", {"help": HELP, "list": ["P0: no device detected"], "data": ["P0M3: +2"]})
    expected = tmp_path / "expect.txt"
    expected.write_text("test_m::help\n")
    comparison = compare_runs("sil:/old", target, [ref, again], read_expect_changes(str(expected)))
    assert [(d.case, d.intended) for d in comparison.differences] == [("test_m::help", True)]
    assert comparison.timing_sensitive == ["test_m::data"] and not comparison.unexpected
    annotate_junit(target, comparison)
    run = read_junit(str(target))
    case = next(c for c in run.cases if c.name == "help")
    assert case.prop("baseline.difference") == "intended"
    assert case.prop("baseline.target_line") == new[1] and case.prop("baseline.baseline_line") == HELP[1]
    section = baseline_section([run])
    assert "sil:/old" in section and "volts!!" in section and "1 case(s) whose HAT output differs" in section
    assert "1 case(s) differ by timing only" in section and "test_m::data" not in section

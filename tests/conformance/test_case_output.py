"""conformance/case_output.py and the judgement of campaigns/mutation.py that uses it: an asynchronous line
that
only fell elsewhere among the answers is no difference; one more, one fewer or a changed one is,
and so are answers in another order. The transcripts are written here, in the transcript format."""
import json

from buildhat_conformance.campaigns.mutation import _differences
from buildhat_conformance.conformance.case_output import (
    case_lines,
    moving_cases,
    same_answers,
    same_output,
    split_asynchronous,
)

VERSION = "Firmware version: 1737564117 2025-01-22T16:41:57+00:00"
PID = "P0: pv=0.00000 sp=0.250000: e=-0.250000 ie=-0.00000 de=25.0000 cv=-0.00000"
REPORT = "P0M3: +49"
# What a case like test_ambiguous_prefix_resolves_by_table_order[s] reads after `s 0.25 ; version`.
REFERENCE = ["", "", VERSION, PID, PID, REPORT, PID]


def _verdicts(tmp_path, name, lines):
    path = tmp_path / f"{name}.jsonl"
    entries = [{"dir": "meta", "case": name}]
    entries += [{"t": i, "dir": "hat", "line": line} for i, line in enumerate(lines)]
    path.write_text("".join(json.dumps(e) + "\n" for e in entries))
    return [("test_abbreviation::case[s]", "pass", ["SYN-ABBREV"], str(path))]


def _differs(tmp_path, lines):
    reference = case_lines(_verdicts(tmp_path, "reference", REFERENCE))
    judged = {c: (["SYN-ABBREV"], got) for c, got in reference.items()}
    return _differences(judged, _verdicts(tmp_path, "mutant", lines))


def test_an_asynchronous_line_moved_across_an_answer_is_no_difference(tmp_path):
    moved = ["", PID, "", VERSION, PID, REPORT, PID]            # a PID line before the fence's answer
    assert _differs(tmp_path, moved) == []
    assert same_output(REFERENCE, moved) and REFERENCE != moved
    assert split_asynchronous(moved) == (["", "", VERSION], [PID, PID, REPORT, PID])


def test_one_more_or_a_changed_asynchronous_line_is_a_difference(tmp_path):
    one_more = ["", REPORT, "", VERSION, PID, PID, REPORT, PID]        # what the five survivors showed
    changed = ["", "", VERSION, PID, PID, "P0M3: +50", PID]
    one_fewer = ["", "", VERSION, PID, REPORT, PID]
    reordered = ["", "", VERSION, PID, REPORT, PID, PID]            # the report one PID line earlier
    for lines in (one_more, changed, one_fewer, reordered):
        assert _differs(tmp_path, lines) == [("test_abbreviation::case[s]", ["SYN-ABBREV"])], lines


def test_answers_in_another_order_are_a_difference(tmp_path):
    assert _differs(tmp_path, ["", VERSION, "", PID, PID, REPORT, PID]) != []
    # A passive device's connect line is also a line of `list`'s answer: its place counts.
    listing = ["P0: connected to passive ID 8", "P1: no device detected", ""]
    assert not same_output(listing, ["P1: no device detected", "P0: connected to passive ID 8", ""])


HELP = ["", "Commands available:", "  help                  : print this help", "", VERSION]
STALL = "deltat=00000003"


def test_a_stall_line_that_moves_with_the_chip_s_phase_leaves_the_answers_compared():
    """Seen in `sil bisect --output`'s phase controls of R7: the pass printing `help` takes 2-3 ms,
    so the `deltat=` line follows the first help case's at one start and the second's at another
    (fb-stall). Those cases are compared by their answers; a case whose answers move is left out."""
    reference = {"help[help]": HELP + [STALL], "help[?]": HELP, "list": ["P0: no device detected"]}
    phase = {"help[help]": HELP, "help[?]": HELP + [STALL], "list": ["P0: no device detected", ""]}
    assert not same_output(reference["help[help]"], phase["help[help]"])
    assert same_answers(reference["help[help]"], phase["help[help]"])
    assert moving_cases(reference, [phase]) == (["list"], ["help[help]", "help[?]"])
    assert moving_cases(reference, [reference]) == ([], [])
    assert moving_cases(reference, [{"list": reference["list"]}]) == (["help[help]", "help[?]"], [])
    # a changed answer line is still a difference by the answers alone
    assert not same_answers(HELP, [line.replace("print this help", "print this") for line in HELP])


def test_a_crlf_cut_between_two_reads_is_a_line_end(tmp_path):
    """Seen in a run: a read ended after a line's CR, the next began with its LF; the transcript
    has a partial ending in CR and a line beginning with LF. Those are the same two lines as a
    run whose reads fell elsewhere."""
    path = tmp_path / "cut.jsonl"
    entries = [{"t": 1, "dir": "hat", "partial": "    format count=1 type=0 chars=1 dp=0\r"},
               {"t": 2, "dir": "hat", "line": "\n    RAW: 00000000 00000002"}]
    path.write_text("".join(json.dumps(e) + "\n" for e in entries))
    got = case_lines([("test_m::case", "pass", [], str(path))])
    assert got["test_m::case"] == ["    format count=1 type=0 chars=1 dp=0", "    RAW: 00000000 00000002"]

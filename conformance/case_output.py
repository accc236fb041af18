"""What the HAT sent in each case of a `sil mutate` run, and when two runs' output of a case
count as the same (campaigns/mutation.py judges survivors and equivalent mutants with it).

A case's output is its whole lines, read from the transcripts in run order as one stream (where
the host's reads cut the stream depends on the wall clock, not on the HAT). Two runs' output of a
case is the same when the answers (every line that is not asynchronous) are equal in order, and
the asynchronous lines are equal in order as a sequence of their own: only where an asynchronous
line falls among the answers may differ. No clause fixes that place (an unasked line may come
between any two lines, docs/FIRMWARE-BEHAVIOUR.md#fb-async), and a mutant that only makes the
firmware a few blocks faster or slower moves it (sil/README.md, "How time works"). One more or one
fewer asynchronous line, or a changed one, is still a difference: a changed report rate shows as
exactly that.
"""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Dict, List, Sequence, Tuple

from ..harness.events import UNASKED_KINDS, classify

__all__ = ["PHASE_CONTROLS_NS", "case_lines", "same_output", "same_answers", "moving_cases",
           "split_asynchronous",
           "first_difference", "read_verdicts", "MOVABLE_KINDS"]

#: The lines whose place among the answers is not compared: the classifier's unasked kinds, but
#: not a passive device's connect line, which is also a line of `list`'s answer (fb-list): there
#: its place is part of the answer, and a list that printed it elsewhere must not pass as the same.
MOVABLE_KINDS = UNASKED_KINDS - {"connected_passive"}

_SYNC_TOKEN = re.compile(r"sync-[0-9a-f]+-\d+")

#: (case, verdict, requirement IDs, transcript path), as campaigns/mutation.py reads them from a JUnit file.
Verdict = Tuple[str, str, List[str], str]

#: Phase controls: runs of the unmutated tree whose chip starts this many ns later after power-on
#: (the stand-in's BUILDHAT_SIL_START_NS). A mutant adds or removes a few blocks (ns to us) and so
#: moves later instants against the world's; a case whose output moves with such a phase cannot
#: tell that mutant from the unmutated firmware on a chip that started a little later.
PHASE_CONTROLS_NS = (3_000, 250_000)



def read_verdicts(junit: Path) -> List[Verdict]:
    """(case, verdict, requirement IDs, transcript path) of every case in a JUnit file of the
    suite, in run order; the case as ``module::case[param]``. No file: no cases."""
    if not junit.exists():
        return []
    out = []
    for case in ET.parse(junit).getroot().iter("testcase"):
        props = {p.get("name"): p.get("value") or "" for p in case.iter("property")}
        reqs = [r for r in props.get("requirements", "").replace(",", " ").split() if r]
        out.append((f"{case.get('classname')}::{case.get('name')}", props.get("verdict", ""), reqs,
                    props.get("transcript", "")))
    return out


def _hat_entries(path: str) -> List[Tuple[bool, str]]:
    """(is a partial, text) of each entry of what the HAT sent in a case's transcript."""
    out: List[Tuple[bool, str]] = []
    try:
        with open(path, encoding="utf-8") as fh:
            for line in fh:
                e = json.loads(line)
                if e.get("dir") == "hat":
                    partial = "partial" in e
                    out.append((partial, str(e["partial"] if partial else e.get("line", e.get("bytes")))))
    except OSError:
        pass
    return out


def case_lines(verdicts: Sequence[Verdict]) -> Dict[str, List[str]]:
    """Each case's HAT lines, without times. The transcripts are read in run order as one
    stream: a ``partial`` entry (the head of a line the reader saw before its end came) is
    joined to what follows, and a line counts in the case where it began. Where the reads cut
    the stream, and so which transcript a line's end lands in, depends on the wall clock, not
    on what the HAT sent (a CRLF cut between two entries is a line end all the same). The
    harness's own sync tokens (a fresh one each run) are blanked."""
    out: Dict[str, List[str]] = {}
    head, head_case = "", ""
    for case, _verdict, _reqs, transcript in verdicts:
        out[case] = []
        for partial, text in _hat_entries(transcript):
            if not head:
                head_case = case
            head += text
            if not partial:
                out[head_case] += _lines(head)
                head = ""
    if head:
        out[head_case] += _lines(head)
    return out


def _lines(text: str) -> List[str]:
    """A joined entry as the HAT's lines: a read can cut a line's CRLF after the CR, so the next
    entry begins with the LF and the two, joined, hold a whole line end."""
    return [_SYNC_TOKEN.sub("sync-*", line) for line in text.split("\r\n")]


def split_asynchronous(lines: Sequence[str]) -> Tuple[List[str], List[str]]:
    """(answers, asynchronous lines), each in the order the HAT sent them."""
    answers: List[str] = []
    unasked: List[str] = []
    for line in lines:
        (unasked if classify(line).kind in MOVABLE_KINDS else answers).append(line)
    return answers, unasked


def same_output(reference: Sequence[str], other: Sequence[str]) -> bool:
    """One case's lines in two runs: the same answers in order and the same asynchronous lines
    in order; only how the two interleave may differ."""
    return list(reference) == list(other) or split_asynchronous(reference) == split_asynchronous(other)


def same_answers(reference: Sequence[str], other: Sequence[str]) -> bool:
    """One case's lines in two runs: the same answers in order, whatever the asynchronous lines.
    For a case whose asynchronous lines move with the chip's phase (a ``deltat=`` stall line: a
    pass of 2-3 ms prints it or not as the 1 ms tick falls, fb-stall) but whose answers do not."""
    return split_asynchronous(reference)[0] == split_asynchronous(other)[0]


def moving_cases(reference: Dict[str, List[str]], controls: Sequence[Dict[str, List[str]]]
                 ) -> Tuple[List[str], List[str]]:
    """(the cases whose answers differ in a control run, or that a control did not run; the
    other cases whose asynchronous lines differ there): the reference run's cases against runs of
    the same firmware (campaigns/mutation.py's phase controls), in the reference's order."""
    answers = [c for c in reference if any(c not in run or not same_answers(reference[c], run[c])
                                           for run in controls)]
    asynchronous = [c for c in reference if c not in answers
                    and any(not same_output(reference[c], run[c]) for run in controls)]
    return answers, asynchronous


def first_difference(reference: Sequence[str], other: Sequence[str]) -> Tuple[str, str]:
    """The first line where two outputs of a case differ by :func:`same_output`'s measure, each
    side's (``(none)`` where one side has no more lines): among the answers if they differ,
    else among the asynchronous lines."""
    ref_parts, other_parts = split_asynchronous(reference), split_asynchronous(other)
    for ref, oth in zip(ref_parts, other_parts):
        if ref != oth:
            for i in range(max(len(ref), len(oth))):
                a = ref[i] if i < len(ref) else "(none)"
                b = oth[i] if i < len(oth) else "(none)"
                if a != b:
                    return a, b
    return "", ""

"""``run --baseline``: the cases whose HAT output differs between two builds, and which of them the
developer meant to change (``--expect-changes FILE``).

A case's output is what the HAT sent in it, compared by ``sil mutate``'s measure
(conformance/case_output.py: the same answers in order and the same asynchronous lines in order; where an
asynchronous line fell among the answers does not count). The baseline runs more than once (again,
and for a ``sil:`` target on a chip started a few microseconds later: campaigns/mutation.py's phase
controls), so what only timing moves is told apart: a case whose output in the target's run equals
any of the baseline's runs is unchanged; one whose output the baseline's own runs do not agree on is
timing-sensitive and not judged; every other difference is listed, with both sides' first differing
lines.

The expect-changes file (docs/COMPARING-BUILDS.md): one case a line, as the JUnit file names it
(``module::case[param]``) or its ``case[param]`` part alone, with ``*`` standing for any text;
``#`` starts a comment; blank lines are ignored.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Sequence, Set, Tuple

from ..plumbing.cli_options import UsageError
from .case_output import case_lines, first_difference, read_verdicts, same_output, split_asynchronous

__all__ = ["Difference", "Comparison", "ExpectedChange", "read_expect_changes", "compare_runs", "judge_case",
           "annotate_junit", "closing_lines", "BASELINE_PROPERTY"]

#: The suite property naming the baseline in the target's JUnit file (conformance/report reads it).
BASELINE_PROPERTY = "baseline"
_CASE_CHARS = re.compile(r"^[^\s#]+$")


@dataclass(frozen=True)
class ExpectedChange:
    pattern: str
    line: int
    regex: re.Pattern[str]

    def matches(self, case: str) -> bool:
        return bool(self.regex.fullmatch(case) or self.regex.fullmatch(case.split("::", 1)[-1]))


def _check_pattern(text: str) -> Optional[str]:
    """Why ``text`` is not a case id or pattern, or None."""
    if not _CASE_CHARS.match(text):
        return "a case id has no spaces (one case or pattern a line; # starts a comment)"
    if text.count("::") > 1:
        return "one '::' at most (module::case[param])"
    if text.startswith("::") or text.endswith("::"):
        return "'::' needs a module before it and a case after it"
    if text.count("[") != text.count("]") or text.count("[") > 1 or (
            "[" in text and not text.endswith("]")):
        return "a case's parameters are one [...] at its end"
    if text.strip("*") == "":
        return "a pattern of '*' alone expects every case to change; name the cases"
    return None


def read_expect_changes(path: str) -> List[ExpectedChange]:
    """The patterns of an expect-changes file; a mistake is a UsageError naming the file and line."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        why = ("no such file" if isinstance(exc, FileNotFoundError) else "not a text file"
               if isinstance(exc, UnicodeDecodeError) else exc.strerror or str(exc))
        raise UsageError(f"--expect-changes {path}: {why}") from None
    out: List[ExpectedChange] = []
    for number, raw in enumerate(text.splitlines(), 1):
        item = raw.split("#", 1)[0].strip()
        if not item:
            continue
        why = _check_pattern(item)
        if why:
            raise UsageError(f"--expect-changes {path}:{number}: {item!r}: {why}")
        regex = re.compile(".*".join(re.escape(part) for part in item.split("*")))
        out.append(ExpectedChange(item, number, regex))
    return out


@dataclass
class Difference:
    case: str
    target_line: str           # the target's first differing line ((none): it had no more)
    baseline_line: str
    intended: bool = False     # named in --expect-changes
    verdicts: Tuple[str, str] = ("", "")    # (target's, baseline's)


@dataclass
class Comparison:
    baseline: str
    differences: List[Difference]
    timing_sensitive: List[str]     # cases that differ only as timing moves output (judge_case)
    only_target: List[str]
    only_baseline: List[str]
    baseline_runs: int
    unmatched: List[ExpectedChange]     # expect-changes lines that matched no listed difference

    @property
    def unexpected(self) -> List[Difference]:
        return [d for d in self.differences if not d.intended]


_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?")


def _masked(lines: Sequence[str]) -> Set[str]:
    return {_NUMBER.sub("#", line) for line in lines}


def judge_case(target: Sequence[str], baseline_runs: Sequence[Sequence[str]]) -> str:
    """``same``, ``timing`` or ``changed``: one case's HAT lines in the target's run against the
    baseline's runs (the reference first).

    - the same as any baseline run (conformance/case_output.py's measure): ``same``;
    - the answers equal to a baseline run's, only asynchronous lines differ (data reports, PID
      lines, ``deltat=``: when they come, and what the motors' samples read then, moves with the
      host's pacing and the chip's phase): ``timing``;
    - the answers differ and the baseline's runs agree on theirs: ``changed``;
    - the answers differ but vary between the baseline's own runs too (an asynchronous line cut
      into an echo, a reply that raced a report): only text counts, numbers aside: a line none of
      the baseline's runs sent, or one every run sent and the target did not, is ``changed``;
      else ``timing``.
    """
    if any(same_output(run, target) for run in baseline_runs):
        return "same"
    answers = split_asynchronous(target)[0]
    theirs = [split_asynchronous(run)[0] for run in baseline_runs]
    if any(answers == other for other in theirs):
        return "timing"
    if all(other == theirs[0] for other in theirs[1:]):
        return "changed"
    seen = set().union(*(_masked(other) for other in theirs))
    always = set.intersection(*(_masked(other) for other in theirs))
    mine = _masked(answers)
    return "changed" if (mine - seen) or (always - mine) else "timing"


def compare_runs(baseline: str, target_junit: Path, baseline_junits: Sequence[Path],
                 expected: Sequence[ExpectedChange] = ()) -> Comparison:
    """Compare the target's run with the baseline's runs (the first is the reference, the rest its
    controls)."""
    target = read_verdicts(target_junit)
    ref = read_verdicts(baseline_junits[0])
    target_lines = case_lines(target)
    runs = [case_lines(ref)] + [case_lines(read_verdicts(j)) for j in baseline_junits[1:]]
    target_verdict = {c: v for c, v, _r, _t in target}
    ref_verdict = {c: v for c, v, _r, _t in ref}
    diffs: List[Difference] = []
    timing: List[str] = []
    for case, _v, _r, _t in target:
        if case not in runs[0]:
            continue
        mine = target_lines[case]
        judged = judge_case(mine, [run[case] for run in runs if case in run])
        if judged == "timing":
            timing.append(case)
        if judged != "changed":
            continue
        target_line, baseline_line = first_difference(mine, runs[0][case])
        diffs.append(Difference(case, target_line, baseline_line,
                                intended=any(e.matches(case) for e in expected),
                                verdicts=(target_verdict.get(case, ""), ref_verdict.get(case, ""))))
    unmatched = [e for e in expected if not any(e.matches(d.case) for d in diffs)]
    return Comparison(baseline, diffs, timing, [c for c in target_verdict if c not in ref_verdict],
                      [c for c in ref_verdict if c not in target_verdict], len(baseline_junits), unmatched)


def _add_properties(elem: ET.Element, pairs: Sequence[Tuple[str, str]]) -> None:
    props = elem.find("properties")
    if props is None:
        props = ET.Element("properties")
        elem.insert(0, props)
    for name, value in pairs:
        ET.SubElement(props, "property", name=name, value=value)


def annotate_junit(junit: Path, comparison: Comparison) -> None:
    """Write the comparison into the target's JUnit file: per differing case
    ``baseline.difference`` (``changed`` or ``intended``), ``baseline.target_line`` and
    ``baseline.baseline_line``; on the suite ``baseline`` (the URL) and ``baseline.changed``,
    ``baseline.intended``, ``baseline.timing_sensitive`` (counts)."""
    tree = ET.parse(junit)
    root = tree.getroot()
    by_case = {d.case: d for d in comparison.differences}
    suite = next(root.iter("testsuite"), None)
    if suite is None:
        return
    intended = len(comparison.differences) - len(comparison.unexpected)
    _add_properties(suite, ((BASELINE_PROPERTY, comparison.baseline),
                            ("baseline.changed", str(len(comparison.unexpected))),
                            ("baseline.intended", str(intended)),
                            ("baseline.timing_sensitive", str(len(comparison.timing_sensitive)))))
    for case in root.iter("testcase"):
        found = by_case.get(f"{case.get('classname')}::{case.get('name')}")
        if found is not None:
            _add_properties(case, (("baseline.difference", "intended" if found.intended else "changed"),
                                   ("baseline.target_line", found.target_line),
                                   ("baseline.baseline_line", found.baseline_line)))
    tmp = junit.with_name(junit.name + ".baseline-tmp")
    tree.write(tmp, encoding="utf-8", xml_declaration=True)
    tmp.replace(junit)


def closing_lines(comparison: Comparison, expect_file: Optional[str] = None) -> List[str]:
    """What the terminal's closing lines say of the comparison."""
    c = comparison
    head = (f"compared with the baseline {c.baseline} ({c.baseline_runs} run(s) of it): "
            f"{len(c.differences)} case(s) whose HAT output differs"
            + (f", {len(c.unexpected)} of them not in {expect_file}" if expect_file is not None else ""))
    out = [head]
    for d in c.differences:
        tag = "intended" if d.intended else ("UNEXPECTED" if expect_file is not None else "changed")
        verdicts = f" (verdict {d.verdicts[1]} -> {d.verdicts[0]})" if d.verdicts[0] != d.verdicts[1] else ""
        out.append(f"  {tag}: {d.case}{verdicts}")
        out.append(f"      target:   {d.target_line!r}")
        out.append(f"      baseline: {d.baseline_line!r}")
    if c.timing_sensitive:
        shown = ", ".join(c.timing_sensitive[:5]) + (" ..." if len(c.timing_sensitive) > 5 else "")
        out.append(f"  {len(c.timing_sensitive)} case(s) differ by timing only (asynchronous lines, or "
                   f"answers the baseline's own runs do not agree on either): {shown}")
    for side, cases in (("the target", c.only_target), ("the baseline", c.only_baseline)):
        if cases:
            out.append(f"  {len(cases)} case(s) ran on {side} only: {', '.join(cases[:5])}"
                       + (" ..." if len(cases) > 5 else ""))
    for e in c.unmatched:
        out.append(f"  {expect_file}:{e.line}: {e.pattern!r} expected a change, but no such case differs")
    return out


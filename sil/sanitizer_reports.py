"""What a firmware in the loop said on stderr when it broke a rule: its reports, one by one.

A sanitized build keeps running after a report where the sanitizer can go on (UBSan, and ASan
built with ``-fsanitize-recover=address``: sil/build.py, sil/process.py), so one run lists every
report, each with the case that met it (sil/README.md, "Crashes and sanitizer reports"). A report
is known by its kind, file and line (:attr:`FirmwareReport.key`): the same defect met again is
the same report.

Suppressions: a file in the sanitizers' own format (``kind:pattern`` lines, ``#`` comments;
the pattern matched as UBSan matches it: a substring of the function, the source file or the
program, ``*`` any run of characters, ``^``/``$`` anchors). The kinds are UBSan's check names
(``shift-base``, ``bounds``, ``null`` ...) and ASan's report kinds (``global-buffer-overflow``
...). The project applies the file itself rather than passing it to the runtime, which would
stay silent about what it suppressed: a suppressed report is still listed, as suppressed.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

__all__ = ["FirmwareReport", "Suppressions", "split_reports", "crash_report", "SuppressionsError"]

_UBSAN_START = re.compile(r"^(?P<file>[^\s:][^:]*):(?P<line>\d+):(?:\d+:)? runtime error: (?P<what>.*)$")
_ASAN_ERROR = re.compile(r"^==\d+==ERROR: (?P<san>\w+Sanitizer): (?P<kind>[\w-]+)")
_ASAN_SUMMARY = re.compile(r"^SUMMARY: \w+Sanitizer: (?P<kind>[\w-]+) (?P<file>[^\s:]+):(?P<line>\d+)"
                           r"(?::\d+)?(?: in (?P<func>\S+))?")
_FRAME = re.compile(r"^\s*#\d+ 0x[0-9a-f]+ in (?P<func>\S+) (?P<file>[^\s:]+):(?P<line>\d+)")

# UBSan's check names (what a suppression names) for its messages.
_UBSAN_KINDS: Sequence[Tuple[str, str]] = (
    ("left shift of", "shift-base"), ("shift exponent", "shift-exponent"),
    ("out of bounds for type", "bounds"), ("with insufficient space for an object", "object-size"),
    ("null pointer passed as argument", "nonnull-attribute"),
    ("null pointer returned from function", "returns-nonnull-attribute"),
    ("null pointer", "null"), ("misaligned address", "alignment"),
    ("signed integer overflow", "signed-integer-overflow"), ("negation of", "signed-integer-overflow"),
    ("division by zero", "integer-divide-by-zero"), ("is outside the range of representable values",
                                                     "float-cast-overflow"),
    ("not a valid value for type 'bool'", "bool"), ("not a valid value for type", "enum"),
    ("pointer overflow", "pointer-overflow"), ("offset to null pointer", "pointer-overflow"),
    ("reached the end of a value-returning function", "return"),
    ("reached an unreachable program point", "unreachable"), ("variable length array bound", "vla-bound"),
    ("passing zero to", "builtin"),
)


class SuppressionsError(ValueError):
    """A suppressions file that cannot be read (one line: why)."""


@dataclass
class FirmwareReport:
    """One report: ``kind`` (a sanitizer check, or the signal of a crash), the firmware's
    ``file`` (its base name) and ``line`` where known, its first line and its whole text."""

    kind: str
    file: str
    line: int
    first: str
    text: str
    fatal: bool = False             # the firmware died of it
    functions: List[str] = field(default_factory=list)   # the frames' functions, innermost first
    paths: List[str] = field(default_factory=list)       # the frames' source files
    suppressed_by: Optional[str] = None                  # the suppression line that covers it

    @property
    def key(self) -> Tuple[str, str, int]:
        return (self.kind, self.file, self.line)

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}" if self.file else "(no source line)"


def _ubsan_kind(what: str) -> str:
    for words, kind in _UBSAN_KINDS:
        if words in what:
            return kind
    return "undefined-behavior"


def _starts(line: str) -> bool:
    return bool(_UBSAN_START.match(line)) or line.startswith("=====") or \
        line.endswith("Sanitizer:DEADLYSIGNAL") or bool(_ASAN_ERROR.match(line))


def _chunks(text: str) -> List[List[str]]:
    """The report's lines, cut where the next report begins (an ASan report's ``=====`` rule and
    the DEADLYSIGNAL line before it belong to it)."""
    out: List[List[str]] = []
    current: List[str] = []
    for line in text.splitlines():
        begins = _starts(line)
        if begins and current and not (line.startswith(("=====", "==")) and (
                current[-1].startswith("=====") or current[-1].endswith("Sanitizer:DEADLYSIGNAL"))):
            out.append(current)
            current = []
        current.append(line)
    if current:
        out.append(current)
    return out


def _parse(lines: List[str]) -> Optional[FirmwareReport]:
    frames = [m for m in (_FRAME.match(ln) for ln in lines) if m]
    functions = [m.group("func") for m in frames]
    paths = [m.group("file") for m in frames]
    text = "\n".join(lines).strip("\n")
    for ln in lines:
        m = _UBSAN_START.match(ln)
        if m:
            name = os.path.basename(m.group("file"))
            first = f"UndefinedBehaviorSanitizer: {ln.strip().replace(m.group('file'), name, 1)}"
            return FirmwareReport(_ubsan_kind(m.group("what")), name, int(m.group("line")), first, text,
                                  functions=functions, paths=[m.group("file")] + paths)
    error = next((m for m in (_ASAN_ERROR.match(ln) for ln in lines) if m), None)
    if error is None:
        return None
    summary = next((m for m in (_ASAN_SUMMARY.match(ln) for ln in lines) if m), None)
    first = next(ln for ln in lines if _ASAN_ERROR.match(ln)).split("==ERROR: ", 1)[1].strip()
    path = summary.group("file") if summary else (paths[0] if paths else "")
    line = int(summary.group("line")) if summary else (int(frames[0].group("line")) if frames else 0)
    # An error the sanitizer cannot go on after (a wild access) ends the program.
    fatal = any(ln.startswith("==") and "ABORTING" in ln for ln in lines)
    return FirmwareReport(error.group("kind"), os.path.basename(path), line, first, text, fatal=fatal,
                          functions=functions, paths=([path] if path else []) + paths)


def split_reports(text: str) -> Tuple[List[FirmwareReport], str]:
    """The reports in a stretch of a firmware's stderr, in order; and what was not part of one."""
    reports: List[FirmwareReport] = []
    other: List[str] = []
    for lines in _chunks(text):
        report = _parse(lines)
        if report is None:
            other.extend(lines)
        else:
            reports.append(report)
    return reports, "\n".join(other)


def crash_report(signal_name: str, text: str, said: str = "") -> FirmwareReport:
    """A death no sanitizer explained (a plain build's SIGSEGV, an emulated chip's stopped core):
    the signal is its kind; ``said`` is the program's own line on it (the rp2040 runner's), if any."""
    first = f"the firmware crashed ({signal_name})" + (f": {said}" if said else "")
    return FirmwareReport(signal_name, "", 0, first, (first + "\n" + text).strip(), fatal=True)


def _template(pattern: str) -> re.Pattern:
    start, end = pattern.startswith("^"), pattern.endswith("$")
    core = pattern[1 if start else 0:len(pattern) - (1 if end else 0)]
    body = ".*".join(re.escape(part) for part in core.split("*"))
    return re.compile(("^" if start else "") + body + ("$" if end else ""))


class Suppressions:
    """The reports a developer has acknowledged: ``kind:pattern`` lines."""

    def __init__(self, rules: Sequence[Tuple[str, str]] = (), program: str = ""):
        self.rules = [(kind, pattern, _template(pattern)) for kind, pattern in rules]
        self.program = program

    @classmethod
    def read(cls, path: str, program: str = "") -> Suppressions:
        try:
            with open(os.path.expanduser(path), encoding="utf-8") as fh:
                text = fh.read()
        except OSError as exc:
            raise SuppressionsError(f"suppressions file {path}: {exc.strerror}") from None
        rules: List[Tuple[str, str]] = []
        for n, raw in enumerate(text.splitlines(), 1):
            line = raw.strip()
            if not line or line.startswith("#"):
                continue
            kind, colon, pattern = line.partition(":")
            if not colon or not kind.strip() or not pattern.strip():
                raise SuppressionsError(f"suppressions file {path}, line {n}: {raw.strip()!r} is not "
                                        "'kind:pattern'")
            rules.append((kind.strip(), pattern.strip()))
        return cls(rules, program)

    def match(self, report: FirmwareReport) -> Optional[str]:
        """The rule (as written) that covers ``report``, else None. UBSan matches the place of
        the error: the innermost frame's function, its file, the program."""
        names = report.functions[:1] + report.paths[:1] + ([self.program] if self.program else [])
        for kind, pattern, rx in self.rules:
            if kind == report.kind and any(rx.search(name) for name in names if name):
                return f"{kind}:{pattern}"
        return None

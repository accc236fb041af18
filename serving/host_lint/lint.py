"""Protocol lint of a host's traffic: what a host library does that works only by luck, or not at all.

The emulator calls the lint after every line it processed (``hat.line_observers``, one ``LineRecord``
per line; see docs/DEVELOPING.md) and feeds it the raw host bytes (``feed_input``). The lint counts, per
session, and keeps the first examples of:

``error``
    every host line that made the HAT print ``Error``.
``not_in_profile``
    a command word the running release does not have but another release does (``bias`` on R6+,
    ``selrate``/``pwmparams``/``port_plimit`` on R1-R4, ``#`` comment lines before R6). On the wrong
    release such a word is an ``Error`` and everything after it on the line is thrown away.
``pid_arity``
    ``pid``/``pid_diff`` with a number of arguments the release does not take: the 2021 document's 10 on
    R6+ (``Error``, and the port is left in direct-PWM mode), or 11 on R1-R5 (the PID applies, then
    ``Error`` for the extra number). FIRMWARE-BEHAVIOUR.md#fb-pid-command, #fb-doc-pid-args.
``crlf``
    a line that starts with (or holds) LF: the host ends lines with CRLF. Only CR ends a line; the LF
    becomes the first byte of the next command, which then fails (#fb-control-bytes).
``before_ready``
    a non-empty line processed before the firmware finished starting up (``Done initialising ports``):
    input sent during the first moments is thrown away byte by byte, so such a host relies on timing.
``overrun``
    more than the HAT can take: the host's lines would fill the HAT's 8192-byte receive ring faster than its
    main loop runs them, so a real HAT drops input (serving/host_lint/intake.py models the ring, the
    115200-baud wire and each line's cost); or, on a paced link (``--baud``), the replies the host asked for
    did not fit the transmit ring and output was dropped. Reported once per episode with its peak.
``unterminated``
    bytes left without a CR when the lint is finished: the HAT never ran them (LF-only line endings).

No fixed rate limit: python-build-hat's own stress tests (112 and 768 lines/s) are what a HAT handles,
and a lint that flags them cries wolf. Rates are in HAT time, so a run at ``--speed N`` judges the host as
if the HAT ran in real time.

``--strict-host`` makes any finding fatal: :meth:`HostLint.fatal_message` names the first offending line.
``@lint`` on the control channel answers :meth:`HostLint.summary_json`.
"""
from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from typing import Any, Callable, Dict, Iterable, List, Optional, Tuple

from ...protocol.profiles import Profile, load_profiles
from .intake import IntakeModel, line_cost_ms

__all__ = ["HostLint", "Finding", "KINDS"]

KINDS = ("error", "not_in_profile", "pid_arity", "crlf", "before_ready", "overrun", "unterminated")
#: Examples kept per kind (the counts are always complete).
KEEP_PER_KIND = 20

_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)$")
_FORMAT = re.compile(r"(u1|s1|u2|s2|u4|s4|f4)$")
_TOKEN = re.compile(r"[^ ;]+|;")


@dataclass
class Finding:
    kind: str
    line: int            # 1-based number of the host line in this session
    t: int               # HAT time in ms when it was processed
    text: str            # the line as the HAT stored it, with control bytes escaped
    detail: str

    def describe(self) -> str:
        return f"line {self.line} (t={self.t} ms) {self.text!r}: {self.kind}: {self.detail}"


@dataclass
class _Episode:
    """An open overrun: on the receive side (``rx``) from the first line that overfilled the ring until it
    drains to half; on the transmit side (``tx``) for as long as consecutive lines lose output."""
    side: str
    start_line: int
    start_t: int
    text: str
    peak: int = 0        # rx: most bytes the ring would hold; tx: output bytes dropped so far

    def finding(self, ring: int) -> Finding:
        if self.side == "tx":
            detail = (f"{self.peak} bytes of the HAT's output did not fit its {ring}-byte transmit ring and "
                      "were dropped: the host asked for more than the wire carries; wait for each reply "
                      "before the next request")
        else:
            detail = (f"the host's lines arrive faster than the HAT runs them: its {ring}-byte receive ring "
                      f"would hold up to {self.peak} bytes (115200-baud wire, each line's cost), so a real "
                      "HAT drops input; wait for replies (or stream with select + selrate) instead")
        return Finding("overrun", self.start_line, self.start_t, self.text, detail)


def _show(raw: bytes) -> str:
    text = raw.decode("latin-1")
    return "".join(ch if " " <= ch <= "~" else repr(ch)[1:-1] for ch in text)[:120]


@lru_cache(maxsize=1)
def _commands_elsewhere() -> Dict[str, List[str]]:
    """Every command name of any release -> the releases that have it."""
    where: Dict[str, List[str]] = {}
    for prof in load_profiles().values():
        for name in prof.commands:
            where.setdefault(name, []).append(prof.name)
    return where


def _release_span(names: List[str]) -> str:
    return names[0] if len(names) == 1 else f"{names[0]}-{names[-1]}"


@dataclass
class HostLint:
    """One session's lint. ``profile_of`` returns the running profile (it changes after an upload);
    it may return None while the bootloader runs, when no firmware command table applies."""

    profile_of: Callable[[], Optional[Profile]]
    strict: bool = False
    on_finding: List[Callable[[Finding], None]] = field(default_factory=list)
    lines: int = 0
    counts: Dict[str, int] = field(default_factory=lambda: {k: 0 for k in KINDS})
    examples: Dict[str, List[Finding]] = field(default_factory=lambda: {k: [] for k in KINDS})
    first: Optional[Finding] = None
    _pending: bytearray = field(default_factory=bytearray)
    _intake: IntakeModel = field(default_factory=IntakeModel)
    _episodes: Dict[str, Optional[_Episode]] = field(default_factory=lambda: {"rx": None, "tx": None})
    _tx_dropped: int = 0
    _rx_dropped: int = 0
    _hat: Any = None
    _finished: bool = False

    # -- wiring -----------------------------------------------------------------------------------------
    @classmethod
    def for_hat(cls, hat: Any, strict: bool = False) -> HostLint:
        """A lint reading ``hat.profile`` and registered in ``hat.line_observers``."""
        lint = cls(profile_of=lambda: getattr(hat, "profile", None), strict=strict)
        lint.attach(hat)
        return lint

    def attach(self, hat: Any) -> None:
        """(Re-)register on a Hat, e.g. the new firmware instance after the bootloader's reboot."""
        self._hat = hat
        self._tx_dropped = int(getattr(getattr(hat, "uart", None), "tx_dropped", 0) or 0)
        self._rx_dropped = int(getattr(getattr(hat, "uart", None), "rx_dropped", 0) or 0)
        self.profile_of = lambda: getattr(hat, "profile", None)
        if self not in hat.line_observers:
            hat.line_observers.append(self)

    def follow(self, emulator: Any) -> None:
        """Keep attached to ``emulator.hat`` (an ``Emulator``), which is replaced when the bootloader
        boots an upload; cheap enough to call after every write or tick. No Hat (bootloader): nothing."""
        hat = getattr(emulator, "hat", None)
        if hat is not None and hat is not self._hat:
            self.attach(hat)

    def __call__(self, record: Any) -> None:
        self.observe(record)

    # -- input ------------------------------------------------------------------------------------------
    def feed_input(self, data: bytes) -> None:
        """Raw bytes from the host, for what no processed line shows: input never ended by a CR."""
        for byte in data:
            if byte == 0x0D:
                self._pending.clear()
            elif len(self._pending) < 256:
                self._pending.append(byte)

    def observe(self, record: Any) -> None:
        """One processed host line: ``LineRecord(raw, now, ready, error, commands, unknown)``."""
        raw: bytes = bytes(record.raw).rstrip(b"\r")
        self.lines += 1
        profile = self.profile_of()
        text = _show(raw)
        now = int(record.now)
        found: List[Finding] = []

        def add(kind: str, detail: str) -> None:
            found.append(Finding(kind, self.lines, now, text, detail))

        if b"\n" in raw:
            where = "starts with" if raw.startswith(b"\n") else "contains"
            add("crlf", f"the line {where} LF: the host ends lines with CRLF (or LF); only CR ends a "
                        "line, so the LF is taken as part of the next command")
        if profile is not None:
            self._check_profile(profile, raw, list(record.unknown or ()), list(record.commands or ()), add)
        if raw.strip(b" \n") and not record.ready:
            add("before_ready", "sent before the firmware finished starting up; input in the first "
                                "moments after reset is discarded")
        if record.error:  # last, so the specific reason comes first in a strict-mode message
            add("error", "the HAT answered Error; the rest of the line was not run")
        self._check_tx_drops(now, text)
        for finding in found:
            self._add(finding)
        self._check_intake(now, text, list(record.commands or ()), raw, profile)

    def finish(self) -> None:
        """End of session: report input the HAT never saw a CR for, and close an open overrun episode.
        Calling it again adds nothing."""
        if self._finished:
            return
        self._finished = True
        editor = getattr(self._hat, "editor", None)
        if editor is not None and getattr(editor, "buffer", None):
            self._pending[:] = bytes(editor.buffer)[:256]
        if self._pending.strip(b" \n"):
            self._add(Finding("unterminated", self.lines + 1, -1, _show(bytes(self._pending)),
                              "bytes not ended by CR (LF-only line endings?); the HAT never ran them"))
            self._pending.clear()
        self._close_episode("rx")
        self._close_episode("tx")

    # -- checks -----------------------------------------------------------------------------------------
    def _check_profile(self, profile: Profile, raw: bytes, unknown: Iterable[str], ran: List[str],
                       found: Callable[[str, str], None]) -> None:
        elsewhere = _commands_elsewhere()
        body = raw.lstrip(b"\n")
        if body.startswith(b"#") and not profile.features.get("hash_comments", False):
            since = [p.name for p in load_profiles().values() if p.features.get("hash_comments")]
            found("not_in_profile", f"'#' comment lines are ignored only by {_release_span(since)}; "
                                    f"{profile.name} {profile.number} answers Error")
        for token in unknown:
            word = token.lstrip("\n")
            owners = elsewhere.get(word)
            if owners and not profile.has(word):
                found("not_in_profile", f"'{word}' is not a command of {profile.name} {profile.number} "
                                        f"(it exists in {_release_span(owners)})")
        want = int(profile.features.get("pid_numbers", 0) or 0)
        if want:
            for name, count in _pid_argument_counts(body.decode("latin-1"), profile):
                if count != want and count in (10, 11):
                    # Still a mistake when an earlier word already failed the line: say it was not reached.
                    reached = "" if name in ran else " (not reached: the line had already failed)"
                    found("pid_arity", f"'{name}' with {count} numbers; {profile.name} {profile.number} "
                                       f"takes {want}" + (" (deadzone last)" if want == 11 else "") + reached)

    def _check_intake(self, now: int, text: str, commands: List[str], raw: bytes,
                      profile: Optional[Profile]) -> None:
        fill = self._intake.line(now, len(raw) + 1, line_cost_ms(profile, raw, commands, self._hat))
        # The emulator's main loop stalls as a HAT's does (#fb-stall), so input also waits in its
        # own RX ring behind a long pass; what that ring holds or had to drop counts too.
        uart = getattr(self._hat, "uart", None)
        held = int(uart.rx_available()) if uart is not None and hasattr(uart, "rx_available") else 0
        dropped = int(getattr(uart, "rx_dropped", 0) or 0)
        if dropped > self._rx_dropped:
            held = max(held, self._intake.ring + dropped - self._rx_dropped)
        self._rx_dropped = dropped
        if max(fill, held) > self._intake.ring:
            self._grow("rx", now, text, max(fill, held))
        elif max(fill, held) <= self._intake.ring // 2:
            self._close_episode("rx")

    def _check_tx_drops(self, now: int, text: str) -> None:
        """Output the paced UART model dropped since the last line (its TX ring was full). Reports are
        throttled before the ring fills (#fb-reporting-r5), so what is dropped is replies to this host's
        requests."""
        dropped = int(getattr(getattr(self._hat, "uart", None), "tx_dropped", 0) or 0)
        if dropped > self._tx_dropped:
            episode = self._grow("tx", now, text, 0)
            episode.peak += dropped - self._tx_dropped
        else:
            self._close_episode("tx")
        self._tx_dropped = dropped

    def _grow(self, side: str, now: int, text: str, level: int) -> _Episode:
        episode = self._episodes[side]
        if episode is None:
            episode = self._episodes[side] = _Episode(side, self.lines, now, text)
        episode.peak = max(episode.peak, level)
        return episode

    def _ring(self, side: str) -> int:
        uart = getattr(self._hat, "uart", None)
        return int(getattr(uart, "tx_size", self._intake.ring)) if side == "tx" else self._intake.ring

    def _close_episode(self, side: str) -> None:
        episode, self._episodes[side] = self._episodes[side], None
        if episode is not None:
            self._add(episode.finding(self._ring(side)))

    def _add(self, finding: Finding) -> None:
        self.counts[finding.kind] += 1
        if len(self.examples[finding.kind]) < KEEP_PER_KIND:
            self.examples[finding.kind].append(finding)
        if self.first is None:
            self.first = finding
        for callback in list(self.on_finding):
            callback(finding)

    # -- results ----------------------------------------------------------------------------------------
    @property
    def clean(self) -> bool:
        return not any(self.counts.values()) and not any(self._episodes.values())

    def summary(self) -> Dict[str, Any]:
        """JSON-ready: counts per kind, kept examples, the intake model. An open overrun episode is in
        both the counts and the findings, as it will be once it closes."""
        counts = dict(self.counts)
        findings = [f for kind in KINDS for f in self.examples[kind]]
        for side, episode in self._episodes.items():
            if episode is not None:
                counts["overrun"] += 1
                findings.append(episode.finding(self._ring(side)))
        profile = self.profile_of()
        return {
            "profile": f"{profile.name} {profile.number}" if profile is not None else None,
            "lines": self.lines,
            "clean": not any(counts.values()),
            "counts": counts,
            "findings": [asdict(f) for f in findings],
            "thresholds": {"rx_ring": self._intake.ring, "wire_baud": 115200},
        }

    def summary_json(self) -> str:
        """One line of JSON (the ``@lint`` reply)."""
        return json.dumps(self.summary(), separators=(",", ":"))

    def report(self) -> str:
        """Human-readable summary for the emulator's exit."""
        summary = self.summary()
        if summary["clean"]:
            return f"host lint: clean ({self.lines} lines)"
        parts = [f"{k}={v}" for k, v in summary["counts"].items() if v]
        out = [f"host lint: {', '.join(parts)} ({self.lines} lines)"]
        kept = sorted((f for kind in KINDS for f in self.examples[kind]),
                      key=lambda f: (f.line, _specific_first(f)))
        out += [f"  {f.describe()}" for f in kept]
        return "\n".join(out)

    def fatal_message(self) -> Optional[str]:
        """Under ``--strict-host``: the message naming the first offending line, else None. An overrun
        still in progress counts (strict mode stops at once, not when the episode ends)."""
        first = self.first
        open_now = [e.finding(self._ring(side)) for side, e in self._episodes.items() if e is not None]
        if first is None:
            if not open_now:
                return None
            first = open_now[0]
        same_line = [f for kind in KINDS for f in self.examples[kind] if f.line == first.line]
        same_line += [f for f in open_now if f.line == first.line]
        reasons = "; ".join(f"{f.kind}: {f.detail}" for f in sorted(same_line, key=_specific_first))
        where = f"line {first.line} (t={first.t} ms) {first.text!r}"
        return f"buildhat-emulator: --strict-host: {where}: {reasons}"


def _specific_first(finding: Finding) -> int:
    return 1 if finding.kind == "error" else 0


def _pid_argument_counts(line: str, profile: Profile) -> List[Tuple[str, int]]:
    """(command, number of arguments) for each pid/pid_diff on the line, as the firmware would resolve
    the words (any prefix, first in table order); arguments are the number or format tokens that follow."""
    tokens = _TOKEN.findall(line)
    out: List[Tuple[str, int]] = []
    i = 0
    while i < len(tokens):
        name = _resolve(tokens[i], profile)
        i += 1
        if name not in ("pid", "pid_diff"):
            continue  # a pid_diff the release lacks is reported as not_in_profile instead
        count = 0
        while i < len(tokens) and (_NUMBER.match(tokens[i]) or _FORMAT.match(tokens[i])):
            count += 1
            i += 1
        out.append((name, count))
    return out


def _resolve(token: str, profile: Profile) -> Optional[str]:
    """The firmware's matcher: the first command in table order that the token is a prefix of."""
    if token == ";":
        return None
    for name in profile.commands:
        if name.startswith(token):
            return name
    return None

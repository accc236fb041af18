"""The state oracle: what a target prints by itself (reports, link changes) and what it drives,
judged against the model's port states. Reports must come only from selections that allow them,
in the selected form (:func:`observe`, which also moves the model on: once-selections end, link
changes reset what it knows); a plain selection on an established device must report within a
long wait (:func:`expect_reports`); a port in direct PWM settles at the duty the facts give
(:func:`check_drive`). Each appends its :class:`Problem` items to the match result and counts its
checks with ``count`` (the campaign's ``Stats.count``); the runner judges them.
"""
from __future__ import annotations

import re
from typing import Callable, Dict, List, Optional, Sequence

from ...harness.events import classify
from ..model.port_model import PortModel, expected_duty
from ..model.reference_model import ReferenceModel
from .built_in import STATE
from .stream_match import MatchResult

__all__ = ["observe", "follow_links", "expect_reports", "check_drive"]

_LINK_KINDS = {"connecting", "established", "disconnected", "timeout", "checksum_error", "too_many_errors",
               "framing_error"}
_REPORT_FORMS = {"mode_data": lambda f: f"M{f['mode']}", "combi_data": lambda f: f"C{f['index']}",
                 "var_data": lambda f: "V"}


def _selection(p: PortModel, selrate_engine: bool) -> str:
    """A port's selection as a finding names it."""
    form = "/".join(p.report_forms()) if p.mode >= 0 else "-"
    return (f"mode {p.mode} form {form} rate {p.rate} "
            f"(reporting {'on' if p.reporting(selrate_engine) else 'off'})")


def observe(model: ReferenceModel, res: MatchResult, states: List[List[PortModel]],
            count: Callable[[str], None]) -> None:
    """The state oracle over asynchronous lines: reports only from selections that allow
    them, in the selected form; connects and disconnects reset what the model knows."""
    for _idx, ev in res.asynchronous:
        port = ev.port
        if port is None or not 0 <= port <= 3:
            continue
        if ev.kind in _LINK_KINDS:
            ident = ev.fields.get("id")
            type_id = ident if ev.kind == "established" and isinstance(ident, int) else None
            # Every state of the step: which of them the line came after is not known.
            for p in [model.ports[port]] + [s[port] for s in states]:
                p.link_changed(type_id)
            continue
        form_of = _REPORT_FORMS.get(ev.kind)
        if form_of is None:
            continue
        count(STATE.name)
        form = form_of(ev.fields)
        # The form follows the HAT's own selection and combi table (fb-data-lines, fb-combi), whatever the
        # device was sent (write1/write2 change what it sends, not how the HAT prints it).
        sources = [s[port] for s in states
                   if not s[port].known or (s[port].reporting(model.selrate_engine)
                                            and form in s[port].report_forms())]
        if not sources:
            before, after = (_selection(s[port], model.selrate_engine) for s in (states[0], states[-1]))
            whose = before if before == after else f"{before} before the step, {after} after it"
            res.problems.append(STATE.problem(f"report {ev.text!r} from port {port}, whose selection is "
                                              f"{whose}"))
            continue
        # The report ends the once-selection that printed it, the first that could have: a
        # report already due when a later select ran belongs to the earlier one (fb-reporting).
        for s in states:
            if s[port].selection == sources[0].selection:
                model.report_seen(s[port])


_LEADING_PROMPTS = re.compile(rb"^(?:P[0-3]>)+")


def follow_links(model: ReferenceModel, data: bytes, states: List[List[PortModel]]) -> None:
    """Link changes in output that no oracle matched (a step judged on liveness only, its raw
    serial trace around them): the model still follows them, as :func:`observe` does, or it
    keeps judging a port by settings a disconnect's port reset has wiped (fb-port-reset)."""
    for raw in data.split(b"\r\n"):
        ev = classify(_LEADING_PROMPTS.sub(b"", raw))
        if ev.kind not in _LINK_KINDS or ev.port is None or not 0 <= ev.port <= 3:
            continue
        ident = ev.fields.get("id")
        type_id = ident if ev.kind == "established" and isinstance(ident, int) else None
        for p in [model.ports[ev.port]] + [s[ev.port] for s in states]:
            p.link_changed(type_id)


def expect_reports(model: ReferenceModel, ms: int, before: List[PortModel], res: MatchResult,
                   count: Callable[[str], None]) -> None:
    """The other half of the state oracle: a plain `select <m>` on an established device that
    has mode m must report within a wait that is long enough (first report about one period
    after the first data, fb-reporting). Only clear cases are judged: no combi, no raw writes to the
    device, no link change, a rate well inside the wait."""
    if ms < 300:
        return
    seen = {(ev.port, _REPORT_FORMS[ev.kind](ev.fields)) for _i, ev in res.asynchronous
            if ev.kind in _REPORT_FORMS}
    changed = {ev.port for _i, ev in res.asynchronous if ev.kind in _LINK_KINDS}
    for port, p in enumerate(before):
        if not (p.known and not p.tampered and not p.var and 0 <= p.mode < min(p.device_modes, 8)
                and not p.combi.get(p.mode) and port not in changed):
            continue
        if model.selrate_engine:
            if not 0 <= p.rate <= ms - 200:
                continue
        elif p.once:
            continue
        count(STATE.name)
        forms = p.report_forms()
        if not any((port, form) in seen for form in forms):
            want = " or ".join(f"P{port}{form}" for form in forms)
            res.problems.append(STATE.problem(f"port {port} has mode {p.mode} selected (rate {p.rate}) on an "
                                              f"established device, but no {want} report came in {ms} ms"))


def check_drive(events: Optional[Sequence[dict]], model: ReferenceModel, ms: int, res: MatchResult,
                count: Callable[[str], None]) -> None:
    """State oracle on the drive, for targets that show it (the in-process emulator's
    ``drive_events``): a port in direct-PWM mode with a known constant setpoint settles at the
    duty fb-pwm-path gives for it and the port's plimit (per release); a coasting port coasts. After a
    ``clear_faults`` a negative duty may show forwards (fb-commands, `clear_faults`) until the drive
    shows its own sign."""
    if events is None or ms < 30:
        return
    changed = {ev.port for _i, ev in res.asynchronous if ev.kind in _LINK_KINDS}
    last: Dict[int, object] = {}
    for ev in events:
        if ev.get("dir") == "pwm":
            last[int(ev["port"])] = ev.get("value")
    for port, p in enumerate(model.ports):
        if p.device_modes <= 0 or port in changed or port not in last:
            continue
        want = expected_duty(model.profile, p, model.plimit)
        if want is None:
            continue
        count(STATE.name)
        if p.forward_flag and isinstance(want, int) and want < 0 and last[port] == -want:
            continue            # still flagged forwards since a clear_faults (fb-commands)
        if last[port] == want:
            p.forward_flag = False      # the driver was written since: its direction is the duty's
            continue
        limit = p.plimit if model.per_port_plimit else model.plimit
        res.problems.append(STATE.problem(f"port {port} drives {last[port]!r}; direct PWM at setpoint "
                                          f"{p.constant} with plimit {limit}/65536 should drive {want!r}"))

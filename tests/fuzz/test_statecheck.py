"""The fuzzer's oracles on a wire where input takes time to arrive (a real HAT at 115200 baud, the
firmware in the loop in HAT time): the HAT may answer between two lines of one input.

FIRMWARE-FACTS §6.2 (R5+): a `selonce` reports as soon as the first matching data message arrives.
If that happens before the next line of the same input has crossed the wire, the report lands
between the two lines' answers, and must be judged by the selection after the first line."""
from __future__ import annotations

from buildhat_conformance.fuzz.model.reference_model import ReferenceModel
from buildhat_conformance.fuzz.model.step_plan import plan_step
from buildhat_conformance.fuzz.oracles.state_check import observe
from buildhat_conformance.fuzz.oracles.stream_match import allowed_kinds, match_stream
from buildhat_conformance.protocol.profiles import get_profile

PRELUDE = (b"echo 0\r", b"debug 0\r", b"port 0\r", b"select\r")


def _model() -> ReferenceModel:
    model = ReferenceModel(get_profile("R7"), {0: ("active", 48), 1: None, 2: None, 3: None})
    for line in PRELUDE:
        model.feed(line)
    return model


def _fence_answer(model: ReferenceModel) -> bytes:
    return b"Firmware version: " + model.profile.version_string.encode() + b"\r\n"


def test_a_once_report_between_two_lines_of_one_input_is_its_selections():
    model = _model()
    # One input of two lines: selonce mode 1, then select mode 0 (and coast).
    plan = plan_step(model, [b"selonc  +1\rselect 0; co\r"])
    # What the firmware in the loop printed (echo off): the first line's CRLF, the once report,
    # the second line's CRLF, reports of mode 0, then the fence's answer.
    got = (b"\r\nP0M1:  0\r\n\r\nP0M0:  0\r\nP0M0:  0\r\n\r\n"
           + _fence_answer(model))
    res = match_stream(plan.expected, got, allowed_kinds(model.profile, 0))
    assert not res.problems, res.problems
    observe(model, res, plan.states, lambda _name: None)
    assert not res.problems, [p.message for p in res.problems]


def test_a_report_of_a_mode_no_line_selected_is_still_a_finding():
    model = _model()
    plan = plan_step(model, [b"selonc  +1\rselect 0; co\r"])
    got = b"\r\nP0M2:  0\r\n\r\n\r\n" + _fence_answer(model)
    res = match_stream(plan.expected, got, allowed_kinds(model.profile, 0))
    observe(model, res, plan.states, lambda _name: None)
    assert [p.oracle for p in res.problems] == ["state"], res.problems


def test_a_line_still_arriving_at_the_end_of_a_wait_is_carried_over_whole():
    """A report that has only begun to cross the wire when a wait ends (no CRLF in the wait's
    output at all) belongs wholly to what comes next; none of its bytes is judged in the wait."""
    from buildhat_conformance.fuzz.running.target_exchange import _incomplete_tail
    assert _incomplete_tail(b"P0V: 0.00000\r", 0) == len(b"P0V: 0.00000\r")
    assert _incomplete_tail(b"P0>P0V: 0.0", 0) == len(b"P0V: 0.0")
    assert _incomplete_tail(b"P0>", 0) == 0
    assert _incomplete_tail(b"P0M0: 1\r\nP0M", 0) == 3


def test_a_disconnect_inside_a_raw_trace_step_still_moves_the_model_on():
    """A step judged on liveness only (debug bit 1's raw trace) can hold a device's timeout; the
    port reset that follows wipes its settings (coast included, §4.2), so the model must follow it
    or the drive oracle judges the empty port by the wiped settings (a sil finding)."""
    from buildhat_conformance.fuzz.model.port_model import expected_duty
    from buildhat_conformance.fuzz.oracles.state_check import follow_links
    model = ReferenceModel(get_profile("R7"), {0: None, 1: ("active", 64), 2: None, 3: None})
    for line in (b"echo 1\r", b"port 1\r", b"coast\r"):
        model.feed(line)
    assert expected_duty(model.profile, model.ports[1], model.plimit) == "coast"
    plan = plan_step(model, [b"debug 1\r"], guard=1)
    got = (b"P1>debug 1\r\nC1t00p3FpC1t00P1>P1: timeout during data phase: disconnecting\r\n"
           b"P1: disconnected\r\nP1>debug 0\r\n")
    follow_links(model, got, plan.states)
    model.ports[:] = plan.states[-1]
    assert model.ports[1].device_modes == 0          # the drive oracle leaves an empty port alone

"""The fuzzer's grammar and reference model against FIRMWARE-FACTS (§1-§3, Appendix A).

These vectors are copied from the facts, not from any emulator output: the model is the fuzzer's
oracle and must be right on its own.
"""
from __future__ import annotations

import pytest

from buildhat_conformance.fuzz.inputs.grammar import grammar_for
from buildhat_conformance.fuzz.model.reference_model import ReferenceModel
from buildhat_conformance.protocol.profiles import get_profile

# §2 "Shortest prefix that resolves to each command" (R6-R7 column, plus R1-R4 differences).
SHORTEST_R7 = {"help": "h", "?": "?", "clear_faults": "c", "port": "p", "list": "l", "ledmode": "le",
               "pwm": "pw", "coast": "co", "pid": "pi", "pid_diff": "pid_", "set": "s", "off": "o",
               "on": "on",
               "vin": "v", "pwmparams": "pwmp", "plimit": "pl", "port_plimit": "port_", "select": "sel",
               "selonce": "selo", "selrate": "selr", "combi": "com", "write1": "w", "write2": "write2",
               "echo": "e", "debug": "d", "version": "ve", "signature": "si"}


def test_grammar_prefixes_follow_the_table_order():
    g = grammar_for("R7")
    assert {r.name: r.prefixes[0] for r in g.commands} == SHORTEST_R7
    r1 = grammar_for("R1")
    assert r1.rule("bias").prefixes[0] == "b" and "selrate" not in [r.name for r in r1.commands]
    assert grammar_for("R5").rule("selrate").prefixes[0] == "selr"
    # "s" and "se" are set; "w".."write" are write1 (§2 ambiguous prefixes)
    assert g.rule("set").prefixes[:2] == ("s", "se")
    assert g.rule("write1").prefixes == ("w", "wr", "wri", "writ", "write", "write1")


def test_grammar_forms_come_from_the_profile():
    assert len(grammar_for("R7").rule("pid").forms[0].args) == 11
    assert len(grammar_for("R4").rule("pid").forms[0].args) == 10
    assert "set.var" in grammar_for("R6").productions and "set.var" not in grammar_for("R5").productions
    assert grammar_for("R7").unknown_words == ("bias",)


def run(profile: str, *lines: bytes, echo: bool = False):
    m = ReferenceModel(get_profile(profile))
    if echo:
        m.feed(b"echo 1\r")
    out, fates = [], []
    for line in lines:
        items, f = m.feed(line)
        out.append(b"".join(i.data for i in items if i.kind == "exact"))
        fates.extend(f)
    return m, out, fates


@pytest.mark.parametrize("line,commands,failed", [
    (b"port 1x\r", ["port"], "x"),            # trailing garbage is the next command (§3)
    (b"p -1\r", [], "port"),
    (b"port 1 vin\r", ["port", "vin"], None),  # no ';' needed between commands
    (b"list 0\r", ["list"], "0"),
    (b"set;0.25\r", ["set"], None),
    (b"port;2\r", ["port"], None),
    (b"set t 0 1 1e3 0\r", [], "set"),         # no exponent: '1' then 'e3' is not a number
    (b"write1 0x12\r", ["write1"], "x12"),     # header 0 sent, then x12 is a command
    (b"select 0 5\r", [], "select"),           # offset without format
    (b"VIN\r", [], "VIN"),
    (b"\tvin\r", [], "\tvin"),
    (b"vin\n\r", [], "vin\n"),
    (b"vin\x00junk\r", ["vin"], None),          # NUL ends the line
    (b"e\r", [], "echo"),
    (b"c\r", ["clear_faults"], None),
    (b"set \xe2\x80\x931\r", [], "set"),       # en dash (§12.14)
    (b"combi 0 1\r", [], "combi"),             # odd number of integers
    (b"ports\r", [], "ports"),
    (b"set sine0 1 2 3 4\r", [], "set"),
    (b"bias .4\r", [], "bias"),                # R6+: no bias
    (b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3\r", [], "pid"),        # 10 numbers on R6+
    (b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3 0.01\r", ["pid"], None),
])
def test_line_fates_r7(line, commands, failed):
    _m, _out, fates = run("R7", line)
    assert fates[0].commands == commands
    assert fates[0].failed == failed


def test_release_differences():
    assert run("R5", b"bias .4\r")[2][0].failed is None
    assert run("R5", b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3 0.01\r")[2][0].commands == ["pid"]
    assert run("R5", b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3 0.01\r")[2][0].failed == "0.01"
    assert run("R4", b"selr 5\r")[2][0].failed == "selr"


def test_state_and_clamping():
    m, _out, _f = run("R7", b"p 9\r")
    assert m.port == 3
    m, _out, _f = run("R7", b"port 1x\r")
    assert m.port == 1
    m, _out, _f = run("R7", b"echo 4294967296\r")     # wraps to 0: echo off
    assert m.echo == 0
    m, _out, _f = run("R7", b"select -1\r")            # clamps to mode 0
    assert m.ports[0].mode == 0 and m.ports[0].rate == 100
    m, _out, _f = run("R7", b"select 0 5\r")
    assert m.ports[0].mode == -1 and m.ports[0].offset == 5
    m, _out, _f = run("R7", b"plimit 1\r")
    assert [p.plimit for p in m.ports] == [65536] * 4
    m, _out, _f = run("R3", b"plimit 0.5\r")
    assert m.plimit == 32768


def test_echo_and_prompt_wire_bytes():
    # §1 echo example (R7): echo 1, port 1, "vinx" BS BS CR
    m = ReferenceModel(get_profile("R7"))
    wire = b""
    for chunk in (b"echo 1\r", b"port 1\r", b"vinx\x08\x08\r"):
        items, _f = m.feed(chunk)
        wire += b"".join(i.data for i in items if i.kind == "exact")
    assert wire == b"\r\nP0>port 1\r\nP1>vinx\x08 \x08\x08 \x08\r\nP1>"   # vin's own line is a pattern
    items, _f = ReferenceModel(get_profile("R7")).feed(b"vi\r")
    assert [i.kind for i in items] == ["exact", "pattern"]


def test_comment_lines():
    _m, out, fates = run("R7", b"# comment\r", echo=True)
    assert out == [b"# comment\r\n"] and fates[0].comment
    _m, out, _f = run("R5", b"# comment\r", echo=True)
    assert out == [b"# comment\r\nError\r\nP0>"]
    _m, _out, fates = run("R7", b" # x\r")
    assert fates[0].failed == "#"


def test_line_buffer_limit():
    # Only the first 256 bytes are kept: 254 spaces + "vi" -> vin, the rest is dropped unechoed.
    _m, _out, fates = run("R7", b" " * 254 + b"vinx junk\r")
    assert fates[0].commands == ["vin"] and fates[0].failed is None
    m, _out, fates = run("R7", b" " * 256 + b"\x08\r")
    assert fates[0].unspecified == ["bs_when_full"] and m.tainted


def test_float_parser_keeps_nine_digits():
    m, _out, _f = run("R7", b"port_plimit 0.0027777778\r")
    assert m.ports[0].plimit == int(0.00277777785 * 65536 + 0.5)
    m, _out, _f = run("R7", b"port_plimit 1234567890123\r")   # clamps to 1
    assert m.ports[0].plimit == 65536


def test_expected_duty_follows_the_drive_path():
    from buildhat_conformance.fuzz.model.port_model import expected_duty
    for release, line, duty in [("R7", b"plimit 1\rset -0.1\r", -26), ("R7", b"plimit 1\rset 0.1\r", 25),
                                ("R7", b"on\r", 25), ("R7", b"set -5\r", -26), ("R7", b"plimit 1\ron\r", 255),
                                ("R7", b"plimit 1\rset -1\r", -255), ("R3", b"plimit 0.5\rset 0.5\r", 127),
                                ("R7", b"coast\r", "coast"), ("R7", b"set 0.5\rcoast\rpwm\r", 25)]:
        m, _out, _f = run(release, line)
        assert expected_duty(m.profile, m.ports[0], m.plimit) == duty, (release, line)
    m, _out, _f = run("R7", b"set sine 0 1 1 0\r")
    assert expected_duty(m.profile, m.ports[0], m.plimit) is None
    m, _out, _f = run("R5", b"bias .2\rset 0.5\r")
    assert expected_duty(m.profile, m.ports[0], m.plimit) is None


def test_a_set_var_failing_in_its_sensor_variable_leaves_a_coasting_drive_unjudged():
    """sil state finding (`--seed 5` and `--seed 1`, 20 s against inprocess): after `coast`, a `set var`
    whose sensor variable fails (`u1` where its offset goes) prints `Error` having stored the shape
    (fb-errors); the facts do not say whether coast ends, and the firmware drives the set-point."""
    from buildhat_conformance.fuzz.model.port_model import expected_duty
    m, _out, fates = run("R7", b"coast\rset var -.6 0.5 676.6 0 3 0 u1 1 0\r")
    assert fates[-1].error
    assert expected_duty(m.profile, m.ports[0], m.plimit) is None
    m, _out, _f = run("R7", b"coast\rset var -.6 0.5 676.6 0 3 0 u1 1 0\rcoast\r")
    assert expected_duty(m.profile, m.ports[0], m.plimit) == "coast"
    # a bad number among the four of the map fails before anything is stored: still coasting
    m, _out, _f = run("R7", b"coast\rset var -.6 x 676.6 0 3 0 0 u1 1 0\r")
    assert expected_duty(m.profile, m.ports[0], m.plimit) == "coast"


def test_drive_oracle_allows_a_reverse_duty_flagged_forwards_by_clear_faults():
    """FIRMWARE-BEHAVIOUR#fb-commands: clear_faults writes every driver's flag register (forwards) and
    the direction is written again only at the next change of sign (the sil finding: +26 after
    `coast`, `set -3011.`, `clear_faults`, where the model said -26)."""
    from buildhat_conformance.fuzz.oracles.state_check import check_drive
    from buildhat_conformance.fuzz.oracles.stream_match import MatchResult

    def judge(m: ReferenceModel, value: object) -> list:
        res = MatchResult()
        check_drive([{"t": 1, "dir": "pwm", "port": 0, "value": value}], m, 100, res, lambda _o: None)
        return res.problems

    m, _out, _f = run("R7", b"set -0.1\r")
    m.ports[0].device_modes = 5                      # a motor is established there
    assert judge(m, 25) and not judge(m, -26)        # without clear_faults the sign is the duty's
    m.feed(b"clear_faults\r")
    assert not judge(m, 26) and not judge(m, -26)    # forwards, or written again since
    assert judge(m, 25)
    assert not judge(m, -26) and judge(m, 26)        # seen reversed: the direction was written again
    m.feed(b"set 0.1\r")
    m.feed(b"clear_faults\r")
    assert not judge(m, 25) and judge(m, -25)        # a forward duty stays what it is


def test_an_odd_combi_leaves_a_streaming_selection_counted_in_the_tx_ring():
    """sil liveness finding (seed 22, 10 min against emulator): `selr` made port 0's combi 6
    stream, then a `combi` with an odd count printed `Error`; the model took the port for silent,
    reckoned nothing queued in the TX ring and sent the fence inside a step whose `help` filled it:
    the fence's answer was lost. The facts leave open whether such a combi clears the selection
    (fb-errors); the firmware in the loop went on reporting (`select 1`, `combi 0 1`: `Error`,
    then `P0M1` lines as before). Unknown, then, but still a selection that may report."""
    from buildhat_conformance.fuzz.model.step_plan import plan_step
    from buildhat_conformance.fuzz.model.tx_ring import THROTTLE, backlog

    m, _out, fates = run("R7", b"select 1\rselrate 1\r")
    plan = plan_step(m, [b"combi 0 1\r"])
    assert plan.fates[0].failed == "combi"
    p = m.ports[0]
    assert not p.known and p.mode == 1                 # the facts do not say; the mode may still report
    assert backlog(plan.states[-1:], 0, m.selrate_engine, True) >= THROTTLE
    # a whole combi clears the selection (fb-reporting): nothing streams after it
    m, _out, fates = run("R7", b"select 1\rselrate 1\rcombi 0 1 0\r")
    assert not fates[-1].error and m.ports[0].known and m.ports[0].mode == -1
    assert backlog([m.ports], 0, m.selrate_engine, True) == 0

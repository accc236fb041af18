"""Comparison rules (transcripts/compare.py): each rule accepts what it should and rejects the rest."""
from __future__ import annotations

import re

import pytest

from buildhat_conformance.transcripts.compare import (
    RuleSet,
    Unit,
    compare_units,
    output_units,
    parse_rule,
    parse_rule_option,
)


def classify(text: str) -> str:
    # A deliberately tiny classifier so these tests do not depend on the session's one.
    if re.fullmatch(r"\d+\.\d\d V", text):
        return "vin"
    if re.match(r"P\dM\d+:", text):
        return "mode_data"
    return "other"


def units(*lines: str, t0: float = 0.0) -> list:
    return [Unit(t0 + 10 * i, s) for i, s in enumerate(lines)]


def run(exp, act, *opts, timing=None):
    return compare_units(exp, act, RuleSet.from_options(opts, timing_ms=timing), classify)


def test_identical_lines_match_exactly():
    c = run(units("", "7.20 V", "Error"), units("", "7.20 V", "Error"))
    assert c.ok and c.compared == 3
    assert c.summary().startswith("MATCH")


def test_exact_rule_rejects_a_one_character_change():
    c = run(units("7.20 V"), units("7.21 V"))
    assert not c.ok
    [d] = c.differences
    assert d.kind == "changed" and d.expected.text == "7.20 V" and d.actual.text == "7.21 V"
    text = c.render()
    assert "- 7.20 V" in text and "+ 7.21 V" in text and "DIFFER" in text


def test_tolerance_accepts_within_and_rejects_beyond():
    assert run(units("7.20 V"), units("7.25 V"), "vin=tolerance:0.05").ok
    c = run(units("7.20 V"), units("7.26 V"), "vin=tolerance:0.05")
    assert not c.ok and "tolerance 0.05" in c.differences[0].reason


def test_tolerance_is_per_number_and_keeps_the_words():
    ok = run(units("P0M2: +100 -5"), units("P0M2: +102 -4"), "data=tolerance:2")
    assert ok.ok
    # the port and mode in "P0M2" are part of the word, not numbers a tolerance may bend
    assert not run(units("P0M2: +100"), units("P1M2: +100"), "data=tolerance:5").ok
    assert not run(units("P0M2: +100"), units("P0M2: +100 +1"), "data=tolerance:5").ok


def test_relative_tolerance():
    assert run(units("P0M1: +1000"), units("P0M1: +1019"), "mode_data=tolerance:2%").ok
    assert not run(units("P0M1: +1000"), units("P0M1: +1021"), "mode_data=tolerance:2%").ok


def test_pattern_rule_checks_the_received_line():
    opt = r"mode_data=pattern:P0M1: [-+]\d+"
    assert run(units("P0M1: +5"), units("P0M1: -77"), opt).ok
    assert not run(units("P0M1: +5"), units("P0M1:  0"), opt).ok


def test_ignore_drops_the_class_on_both_sides_and_counts_it():
    exp = units("", "P0M1: +1", "P0M1: +2", "7.20 V")
    act = units("", "P0M1: +9", "7.20 V")
    c = run(exp, act, "data=ignore")
    assert c.ok and c.ignored == {"mode_data": 3}
    assert "3 line(s) ignored" in c.summary()


def test_missing_and_extra_lines_keep_the_rest_aligned():
    c = run(units("a", "b", "c", "d"), units("a", "c", "d", "e"))
    kinds = [(d.kind, (d.expected or d.actual).text) for d in c.differences]
    assert kinds == [("missing", "b"), ("extra", "e")]


def test_tolerated_reading_does_not_push_the_diff_out_of_step():
    exp = units("x", "7.20 V", "y", "z")
    act = units("x", "7.24 V", "y", "q")
    c = run(exp, act, "vin=tolerance:0.05")
    assert [(d.kind, d.expected.text) for d in c.differences] == [("changed", "z")]


def test_timing_tolerance():
    exp = [Unit(100, "7.20 V")]
    assert run(exp, [Unit(140, "7.20 V")], timing=50).ok
    c = run(exp, [Unit(160, "7.20 V")], timing=50)
    assert [d.kind for d in c.differences] == ["timing"]
    assert run(exp, [Unit(900, "7.20 V")]).ok  # times are not compared unless asked


def test_render_names_the_host_line_before_a_difference():
    host = [{"t": 0, "dir": "host", "bytes": "vin\r"}]
    text = run(units("", "7.20 V"), units("", "8.00 V")).render(host)
    assert "after host b'vin\\r' at t=0 ms" in text


def test_output_units_join_a_prompt_with_the_echo_that_follows():
    events = [
        {"t": -5, "dir": "hat", "line": "Done initialising ports"},
        {"t": 0, "dir": "hat", "line": ""},
        {"t": 0, "dir": "hat", "partial": "P0>"},
        {"t": 10, "dir": "host", "bytes": "p 2\r"},
        {"t": 10, "dir": "hat", "line": "p 2"},
        {"t": 10, "dir": "hat", "partial": "P2>"},
    ]
    got = output_units(events)
    assert [(u.text, u.partial) for u in got] == [("", False), ("P0>p 2", False), ("P2>", True)]
    assert output_units(events, since=-100)[0].text == "Done initialising ports"


def test_an_answer_belongs_to_its_host_line_however_fast_the_host_typed():
    # Recorded: each answer before the next line was typed. Replayed on a loaded machine: the
    # host typed all three lines before the first answer came. The answers are the same.
    recorded = [
        {"t": 0, "dir": "host", "bytes": "version\r"}, {"t": 1, "dir": "hat", "line": ""},
        {"t": 1, "dir": "hat", "line": "Firmware version: 1"},
        {"t": 2, "dir": "host", "bytes": "vin\r"}, {"t": 3, "dir": "hat", "line": ""},
        {"t": 3, "dir": "hat", "line": "8.00 V"},
        {"t": 4, "dir": "host", "bytes": "bias .4\r"}, {"t": 5, "dir": "hat", "line": ""},
    ]
    typed_ahead = [
        {"t": 0, "dir": "host", "bytes": "version\r"}, {"t": 2, "dir": "host", "bytes": "vin\rbi"},
        {"t": 3, "dir": "host", "bytes": "as .4\r"},
        {"t": 5, "dir": "hat", "line": ""}, {"t": 5, "dir": "hat", "line": "Firmware version: 1"},
        {"t": 5, "dir": "hat", "line": ""}, {"t": 5, "dir": "hat", "line": "8.00 V"},
        {"t": 5, "dir": "hat", "line": ""},
    ]
    assert [u.host_index for u in output_units(recorded)] == [1, 1, 2, 2, 3]
    assert [u.host_index for u in output_units(typed_ahead)] == [1, 1, 2, 2, 3]
    assert run(output_units(recorded), output_units(typed_ahead)).ok
    # The same answers under other host lines still differ: "8.00 V" answering `bias` is not it.
    moved = typed_ahead[:6] + [typed_ahead[7], typed_ahead[6]]
    assert [u.host_index for u in output_units(moved)] == [1, 1, 2, 3, 3]
    assert not run(output_units(recorded), output_units(moved)).ok


def test_with_echo_on_the_echo_ends_the_host_line():
    events = [{"t": 0, "dir": "host", "bytes": "vin\rvin\r"}, {"t": 1, "dir": "hat", "line": "vin"},
              {"t": 1, "dir": "hat", "line": "8.00 V"}, {"t": 1, "dir": "hat", "partial": "P0>"},
              {"t": 1, "dir": "hat", "line": "vin"}, {"t": 1, "dir": "hat", "line": "8.00 V"}]
    assert [u.host_index for u in output_units(events)] == [1, 1, 2, 2]


@pytest.mark.parametrize("bad", ["vin", "vin=", "=exact", "vin=fuzzy", "vin=tolerance:x",
                                 "vin=pattern:(", "vin=exact:1", "vin=tolerance:-1"])
def test_bad_rule_options_are_refused_with_a_reason(bad):
    with pytest.raises(ValueError) as info:
        parse_rule_option(bad)
    assert str(info.value)


def test_alias_and_default():
    assert [c for c, _ in parse_rule_option("data=ignore")] == ["mode_data", "combi_data", "var_data"]
    rs = RuleSet.from_options(["*=ignore", "vin=exact"])
    assert rs.rule_for("vin").kind == "exact" and rs.rule_for("anything").kind == "ignore"
    assert str(parse_rule("tolerance:2%")) == "tolerance:2%"

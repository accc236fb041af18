"""The oracle registry (fuzz/oracles/registry.py) and the fuzzer's own oracles in it (built_in.py)."""
from __future__ import annotations

import pickle

import pytest

from buildhat_conformance.fuzz.oracles import built_in
from buildhat_conformance.fuzz.oracles.registry import (
    ALWAYS,
    WHERE_CHECKED,
    WITH_AGAINST,
    Finding,
    Oracle,
    finding_class,
    oracle_named,
    oracle_names,
    oracles,
    register,
    unregister,
)


def test_the_fuzzers_own_oracles_come_first_in_the_junit_order():
    own = ("liveness", "fate", "state", "hygiene", "differential", "crash", "sanitizer")
    assert oracle_names()[:7] == own
    assert oracle_named("fate") is built_in.FATE


def test_of_two_problems_in_one_answer_a_reboot_then_a_stray_line_then_the_answer_then_the_state_wins():
    ranked = sorted(("state", "fate", "hygiene", "liveness"), key=lambda name: oracle_named(name).priority)
    assert ranked == ["liveness", "hygiene", "fate", "state"]


def test_which_oracles_judge_every_answer_and_which_lose_the_target():
    assert [o.name for o in oracles() if o.per_answer][:3] == ["fate", "state", "hygiene"]
    assert [o.name for o in oracles() if o.target_lost] == ["liveness", "crash"]


def test_junit_cases_follow_each_oracles_rule():
    assert built_in.STATE.has_case(against=False, checks={}, found=False)
    assert built_in.DIFFERENTIAL.case == WITH_AGAINST
    assert not built_in.DIFFERENTIAL.has_case(against=False, checks={"differential": 3}, found=False)
    assert built_in.DIFFERENTIAL.has_case(against=True, checks={}, found=False)
    assert built_in.CRASH.case == WHERE_CHECKED
    assert not built_in.CRASH.has_case(against=True, checks={"fate": 9}, found=False)
    assert built_in.CRASH.has_case(against=False, checks={"crash": 1}, found=False)
    assert built_in.SANITIZER.has_case(against=False, checks={}, found=True)


def test_each_oracle_has_a_finding_class_of_its_own_that_survives_a_pipe():
    finding = finding_class("state")("port 0 drives 5", [], {"step": b"pwm\r"})
    assert isinstance(finding, Finding) and finding.oracle == "state"
    assert str(finding) == "[state] port 0 drives 5"
    again = pickle.loads(pickle.dumps(finding))      # (a --jobs worker sends its findings so)
    assert type(again) is type(finding) and again.message == finding.message
    assert again.details == {"step": b"pwm\r"} and str(again) == str(finding)
    with pytest.raises(ValueError, match=r"unknown oracle 'nope' \(known: liveness, fate, "):
        finding_class("nope")


def test_a_problem_names_its_oracle():
    problem = built_in.HYGIENE.problem("stray", (1, 2))
    assert (problem.oracle, problem.message, problem.at) == ("hygiene", "stray", (1, 2))


def test_a_registered_oracle_comes_after_the_others_and_a_second_of_its_name_is_refused():
    added = Oracle("registry_test", "checks nothing", priority=20, per_answer=True, check=lambda answer: ())
    try:
        assert register(added) is added and register(added) is added      # (a module imported again)
        assert oracle_names()[-1] == "registry_test" and added.case == ALWAYS
        with pytest.raises(ValueError, match="registered already"):
            register(Oracle("registry_test", "another", priority=1))
    finally:
        unregister("registry_test")
    assert "registry_test" not in oracle_names()


def test_an_oracle_says_what_it_is_wrong_about():
    with pytest.raises(ValueError, match="case 'sometimes'"):
        Oracle("x", "x", priority=1, case="sometimes")
    with pytest.raises(ValueError, match="per_answer=True"):
        Oracle("x", "x", priority=1, check=lambda answer: ())

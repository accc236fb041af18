"""Fuzz inputs from the grammar (fuzz/inputs/generate.py): a pure function of the seed, every input one or
more whole lines ending in CR, each family what it says, and unknown families refused."""
from __future__ import annotations

import random

import pytest

from buildhat_conformance.fuzz.inputs.generate import FAMILIES, InputGenerator
from buildhat_conformance.fuzz.inputs.grammar import grammar_for


def _draw(seed: int, n: int = 300, families=FAMILIES) -> list:
    gen = InputGenerator(grammar_for("R7"), families)
    rng = random.Random(seed)
    return [gen.input(rng) for _ in range(n)]


def test_the_same_seed_gives_the_same_inputs_and_another_seed_others():
    assert _draw(7) == _draw(7)
    assert [i.data for i in _draw(7)] != [i.data for i in _draw(8)]


def test_every_input_ends_in_cr_and_every_family_shows_up():
    inputs = _draw(1, 500)
    assert all(i.data.endswith(b"\r") for i in inputs)
    assert {i.family for i in inputs} == set(FAMILIES)


def test_valid_inputs_start_with_a_command_of_the_release():
    names = set(grammar_for("R7").profile.commands)
    for i in _draw(3, 200, ("valid",)):
        word = i.data.lstrip(b" ;").split(b"\r")[0].replace(b";", b" ").split(b" ")[0].decode()
        # the word is a command's name or a prefix that resolves to one (fb-matching)
        assert any(n.startswith(word) for n in names) and word, i
        assert i.productions, i


def test_unknown_families_are_refused():
    with pytest.raises(ValueError, match="unknown input families"):
        InputGenerator(grammar_for("R7"), ("valid", "haiku"))
    with pytest.raises(ValueError):
        InputGenerator(grammar_for("R7"), ())

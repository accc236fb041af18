"""Issue 38: the cases' order, the suite's own or shuffled by pytest-randomly with a seed; cases
marked ``together`` stay next to each other (conformance/case_order.py). Whole shuffled runs are
in tests/end_to_end/test_conformance_case_order.py."""
from __future__ import annotations

import importlib.util
from types import SimpleNamespace
from typing import Any, List, Optional

import pytest

from buildhat_conformance.conformance.case_order import keep_together, order_argv, resolve_seed


def test_the_suite_s_own_order_switches_pytest_randomly_off() -> None:
    assert order_argv(None) == ["-p", "no:randomly"]
    assert order_argv(7) == ["-p", "randomly", "--randomly-seed=7"]
    assert resolve_seed(None) is None


@pytest.mark.skipif(importlib.util.find_spec("pytest_randomly") is None, reason="needs pytest-randomly")
def test_a_seed_is_a_whole_number_or_a_new_one() -> None:
    assert resolve_seed("42") == 42
    seeds = {resolve_seed("random") for _ in range(5)}
    assert all(isinstance(s, int) and 0 <= s < 2 ** 32 for s in seeds) and len(seeds) > 1
    with pytest.raises(ValueError, match=r"--random-order x1: a seed is a whole number"):
        resolve_seed("x1")


class Case:
    """A collected case as keep_together sees it: a name, where it is written, its marker."""

    def __init__(self, name: str, line: int, group: Optional[str] = None):
        self.name, self.fspath, self.location = name, "cases/test_x.py", ("cases/test_x.py", line, name)
        self._mark = SimpleNamespace(name="together", args=(group,)) if group else None

    def get_closest_marker(self, name: str) -> Any:
        return self._mark if name == "together" else None


def test_cases_that_share_state_stay_together_in_their_written_order() -> None:
    items: List[Any] = [Case("a", 1), Case("g2", 20, "g"), Case("b", 2), Case("g1", 10, "g"), Case("c", 3),
                        Case("h1", 30, "h")]
    keep_together(items)
    assert [i.name for i in items] == ["a", "g1", "g2", "b", "c", "h1"]

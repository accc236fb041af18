"""Budgets (fuzz/running/budget.py): the fuzzing budget and the bound on checking findings."""
from __future__ import annotations

import pytest

from buildhat_conformance.fuzz.running.budget import CHECK_SHARE, Budget, check_limit, parse_seconds


def test_checking_is_bounded_by_a_share_of_a_time_budget_unless_told():
    assert CHECK_SHARE == 0.25
    assert check_limit(Budget(seconds=20), None) == 5.0
    assert check_limit(Budget(seconds=600), None) == 150.0
    assert check_limit(Budget(seconds=20), "2m") == 120.0
    assert check_limit(Budget(seconds=20), "0") == 0.0          # no checking at all
    assert check_limit(Budget(examples=500), None) is None     # runs: each finding's own bounds
    assert check_limit(Budget(examples=500), "90s") == 90.0


def test_a_check_time_takes_seconds_or_units_and_refuses_the_rest():
    assert parse_seconds("90", "--check-time") == 90.0
    assert parse_seconds("1.5m", "--check-time") == 90.0
    assert parse_seconds("1h", "--check-time") == 3600.0
    for bad in ("-1", "ten", "5x", ""):
        with pytest.raises(ValueError, match="--check-time takes a duration"):
            parse_seconds(bad, "--check-time")

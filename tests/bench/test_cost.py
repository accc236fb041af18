"""The emulator's cost benchmark (bench/cost.py), in small: every host line it sends is answered and
counted, so a figure is never computed over lines that were silently dropped. No timing is asserted."""
from __future__ import annotations

import pytest

from buildhat_conformance.bench import cost


def test_memory_after_a_few_thousand_lines_counts_every_answer():
    got = cost.memory_in_this_process(lines=2000, batch=100)
    assert set(got) == {"rss_mib", "rss_growth_mib", "lines_per_s"} and got["lines_per_s"] > 0


def test_lines_that_go_unanswered_are_caught(monkeypatch):
    # A link that loses the second half of every batch: the measurement must say so, not report a figure.
    from buildhat_conformance.emulator import Emulator

    write = Emulator.write
    monkeypatch.setattr(Emulator, "write", lambda self, data: write(self, data[:len(data) // 2]))
    with pytest.raises(RuntimeError, match="1000 of 2000 lines answered"):
        cost.memory_in_this_process(lines=2000, batch=100)

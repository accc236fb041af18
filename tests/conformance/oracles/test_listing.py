"""The suite's list oracle (conformance/oracles/listing.py) against the catalogue's dumps."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.oracles.listing import ListError, parse_list, render_active
from buildhat_conformance.protocol.devices import catalogue


def test_list_renderer_reproduces_every_catalogue_block() -> None:
    for key, device in catalogue().items():
        if key.startswith("0x"):
            assert render_active(0, device) == device["hat_list_lines"], key


def test_list_grammar_accepts_a_dump_and_rejects_a_broken_one() -> None:
    good = render_active(0, catalogue()["0x30"]) + ["P1: no device detected", "P2: connected to passive ID 8",
                                                   "P3: no device detected"]
    assert [e.kind for e in parse_list(good)] == ["active", "empty", "passive", "empty"]
    for broken in (good[:-1], good + ["junk"], [good[0].replace("30", "31")] + good[1:],
                   [ln.rstrip() for ln in render_active(0, catalogue()["0x40"])] + good[-3:]):
        with pytest.raises(ListError):
            parse_list(broken)

"""conformance/oracles/startup.py: the start-up lines after a reset (docs/FIRMWARE-BEHAVIOUR.md#fb-startup)
and what a reset that cut a line may leave before them."""
from __future__ import annotations

from buildhat_conformance.conformance.oracles.startup import START_UP, start_up_after_reset

BANNER = START_UP[1:]          # from `Type help <RETURN> for help` on


def test_a_clean_start_up_has_no_leftover():
    got = start_up_after_reset(["P0: established serial communication with active ID 30", ""] + BANNER)
    assert got.lines == START_UP and got.leftover == ""


def test_a_line_cut_by_the_reset_is_set_apart():
    for cut in ("deltat=00000", "P0M1: 12 3", "P0: pv=0.1", "\x00", "deltat=00000003"):
        got = start_up_after_reset([cut] + BANNER)
        assert got.lines == START_UP and got.leftover == cut, cut


def test_a_missing_empty_line_is_not_excused():
    assert start_up_after_reset(BANNER).lines == []                   # nothing before `Type help`
    for before in ("Error", "P0: no device detected", "  nmodes =5", "Firmware version: 1737564117"):
        got = start_up_after_reset([before] + BANNER)
        assert got.lines[0] == before and got.lines != START_UP and got.leftover == "", before


def test_a_changed_banner_line_shows():
    got = start_up_after_reset(["deltat=0000", "Type help <RETURN> for help", "Initialising ports",
                                "Done initialising ports"])
    assert got.leftover == "deltat=0000" and got.lines != START_UP
    assert start_up_after_reset(["no banner here"]).lines == []

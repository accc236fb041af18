"""Evidence that the suite can fail: each mutant emulator breaks ONE behaviour
(tests/mutants/line_mutations.py); the cases for that behaviour must fail and the
others must still pass.

Every mutant runs in virtual time on the in-process emulator (tests/mutants/mutant_target.py):
the suite's logic is what is tested, not the wire. One mutant also runs as the pty relay in front
of the real emulator process (tests/mutants/mutant_emulator.py), so that path stays covered too:
``lf-ignored``, whose bytes (a CR LF pair from the host) are the ones a pty could alter."""
from __future__ import annotations

from typing import List

import pytest
from mutants.suite_run import run_suite

# mutation -> (cases that must fail, cases that must not)
MUTANTS = {
    "vin-off-by-one": (["test_commands.py::test_vin_follows_the_supply_and_rounds_a_5_down[1742]"],
                       ["test_commands.py::test_port_above_3_is_clamped_to_3[port 9]"]),
    "error-swallowed": (["test_commands.py::test_unknown_command_prints_exactly_error[bogus]"],
                        ["test_commands.py::test_vin_prints_volts_with_two_decimals"]),
    "prefix-last-match": (["test_abbreviation.py::test_ambiguous_prefix_resolves_by_table_order[v]"],
                          ["test_commands.py::test_vin_prints_volts_with_two_decimals"]),
    # The light matrix has modes with an empty symbol (devices.json 0x40 M2, M3).
    "list-symbol-space-dropped": (["test_list.py::test_active_device_block_matches_the_catalogue[0x40]"],
                                  ["test_commands.py::test_vin_prints_volts_with_two_decimals"]),
    "lf-ignored": (["test_link.py::test_crlf_from_the_host_breaks_the_next_line"],
                   ["test_link.py::test_cr_always_answers_crlf"]),
    "done-dropped": (["test_waveforms.py::test_pulse_holds_then_settles_and_reports_done[1 0 0.1 0]"],
                     ["test_waveforms.py::test_periodic_waveform_tick_by_tick[square 0 1 0.2 0]"]),
    "port-fault-not-repeated": (
        ["test_faults.py::test_port_power_fault_repeats_while_present_and_stops_after"],
        ["test_faults.py::test_clear_faults_with_the_cause_still_present"]),
    "pid-output-sign-flipped": (["test_pid.py::test_pid_lines_match_a_float32_recomputation",
                                 "test_pid.py::test_pid_lines_are_self_consistent_on_live_data"],
                                ["test_waveforms.py::test_ramp_fourth_parameter"]),
}
pytestmark = pytest.mark.timeout(300)


def _name(case: str) -> str:
    return case.split("::", 1)[1]


# (mutation, target): all in virtual time, one also over the pty relay.
CASES = [(m, "inprocess:R7") for m in sorted(MUTANTS)] + [("lf-ignored", "emulator:R7")]


@pytest.mark.parametrize(("mutation", "target"), CASES, ids=[f"{m}-{t.split(':')[0]}" for m, t in CASES])
def test_mutant_is_caught_by_its_tests_only(tmp_path, mutation: str, target: str) -> None:
    must_fail, must_pass = MUTANTS[mutation]
    results = run_suite(str(tmp_path), target, must_fail + must_pass, mutation=mutation, timeout=280)
    verdicts = {name: r.verdict for name, r in results.items()}
    caught: List[str] = [c for c in must_fail if verdicts.get(_name(c)) != "fail"]
    assert not caught, f"{mutation}: these cases did not fail: {caught} (verdicts {verdicts})"
    hurt = [c for c in must_pass if verdicts.get(_name(c)) not in ("pass", "known deviation")]
    assert not hurt, f"{mutation}: unrelated cases failed too: {hurt} (verdicts {verdicts})"

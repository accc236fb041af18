"""The command dispatcher's table (emulator/commands/dispatch.py): the profile's commands in the firmware's
matching order, each with its implementation (docs/FIRMWARE-BEHAVIOUR.md#fb-command-table)."""
from __future__ import annotations

import pytest

from buildhat_conformance.emulator.commands.dispatch import command_table
from buildhat_conformance.protocol.profiles import get_profile

# fb-command-table, transcribed.
R1_R4 = ("help, ?, clear_faults, port, list, ledmode, pwm, coast, pid, set, off, on, vin, bias, plimit, "
         "select, selonce, combi, write1, write2, echo, debug, version, signature").split(", ")
R6_R7 = ("help, ?, clear_faults, port, list, ledmode, pwm, coast, pid, pid_diff, set, off, on, vin, "
         "pwmparams, plimit, port_plimit, select, selonce, selrate, combi, write1, write2, echo, debug, "
         "version, signature").split(", ")
R5 = R1_R4[:R1_R4.index("selonce") + 1] + ["selrate"] + R1_R4[R1_R4.index("selonce") + 1:]


@pytest.mark.parametrize("release,order", [("R1", R1_R4), ("R4", R1_R4), ("R5", R5), ("R6", R6_R7),
                                           ("R7", R6_R7)])
def test_each_release_has_its_table_in_order_and_an_implementation_for_each(release, order):
    names, table = command_table(tuple(get_profile(release).commands))
    assert list(names) == order
    assert set(table) == set(order) and all(callable(fn) for fn in table.values())


def test_a_command_nothing_implements_is_a_data_error():
    with pytest.raises(KeyError, match="frobnicate"):
        command_table(("help", "frobnicate"))

"""The suite's command-prefix oracle (conformance/oracles/commands.py) against FIRMWARE-FACTS §2."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.oracles.commands import (
    ambiguous_prefixes,
    resolve,
    shortest_resolving_prefix,
    unique_prefix,
)
from buildhat_conformance.protocol.profiles import get_profile

# FIRMWARE-FACTS §2, "Shortest prefix that resolves to each command".
SHORTEST = {"R1": {"help": "h", "clear_faults": "c", "ledmode": "le", "coast": "co", "set": "s", "on": "on",
                   "bias": "b", "select": "sel", "selonce": "selo", "combi": "com", "write1": "w",
                   "write2": "write2", "version": "ve", "signature": "si", "vin": "v", "off": "o"},
            "R5": {"selrate": "selr", "select": "sel"},
            "R7": {"pid_diff": "pid_", "pwmparams": "pwmp", "port_plimit": "port_", "pid": "pi", "pwm": "pw"}}


@pytest.mark.parametrize("release", sorted(SHORTEST))
def test_shortest_prefixes_from_the_tables(release: str) -> None:
    table = get_profile(release).commands
    for name, prefix in SHORTEST[release].items():
        assert shortest_resolving_prefix(name, table) == prefix


def test_prefix_resolution_and_the_documents_rule() -> None:
    r1, r7 = get_profile("R1").commands, get_profile("R7").commands
    assert resolve("b", r7) is None and resolve("vinx", r1) is None and resolve("co", r1) == "coast"
    assert unique_prefix("coast", r1) == "coa" and unique_prefix("pid", r7) is None
    amb = {p: first for p, first, _names in ambiguous_prefixes(r1)}
    assert amb["c"] == "clear_faults" and amb["v"] == "vin" and amb["write"] == "write1" and "e" not in amb

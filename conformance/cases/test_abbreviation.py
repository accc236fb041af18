"""SYN-ABBREV: command names may be abbreviated.

Document: "Any command can be abbreviated to its shortest unique prefix".
docs/FIRMWARE-BEHAVIOUR.md#fb-matching: any non-empty prefix is accepted and the *first* name in the
release's table order wins. The document leaves ambiguous prefixes open, so what they do is reported
as *informational*; it must still be what #fb-ambiguous says the release does (the earlier command
runs). A token longer
than a name never matches it; matching is case-sensitive. Every expectation here is
computed from the target profile's command table by ``oracles/commands.py``.
"""
from __future__ import annotations

from typing import List

import pytest

from ...protocol.profiles import get_profile, load_profiles
from ..command_probes import probe
from ..hat_under_test import HatUnderTest
from ..oracles.commands import ambiguous_prefixes, resolve, shortest_resolving_prefix, unique_prefix
from ..verdict import Verdict

ALL_COMMANDS: List[str] = sorted({c for p in load_profiles().values() for c in p.commands})
DOCUMENT_COMMANDS = get_profile("R1").commands     # the document's set is R1-R4's (#fb-releases)
ALL_AMBIGUOUS: List[str] = sorted({prefix for p in load_profiles().values()
                                   for prefix, _first, _names in ambiguous_prefixes(p.commands)})


def _expect_runs(hat: HatUnderTest, port: int, token: str, command: str) -> None:
    out = probe(hat, port, command, token)
    if out.error:
        raise AssertionError(f"sent `{token}`: expected it to run {command}; came `Error` ({out.seen})")
    assert out.ran, f"sent `{token}`: expected it to run {command}; it answered, but {out.seen}"


def _expect_error(hat: HatUnderTest, token: str) -> None:
    reply = hat.exchange(token)
    assert reply.raw == b"\r\nError\r\n", f"`{token}` names no command here; got {reply.raw!r}"


@pytest.mark.req("SYN-ABBREV")
@pytest.mark.parametrize("command", ALL_COMMANDS)
def test_shortest_resolving_prefix_runs_the_command(hat: HatUnderTest, motor_port: int, verdict: Verdict,
                                                    command: str) -> None:
    table = hat.commands
    if command not in table:
        # Not a command of this release: its full name must be rejected (or mean another).
        other = resolve(command, table)
        if other is None:
            reply = hat.exchange(command)
            rejected = reply.raw == b"\r\nError\r\n"
            if command in DOCUMENT_COMMANDS:
                verdict.document(False, key="BIAS-REMOVED", firmware_ok=rejected, seen=repr(reply.raw))
            else:
                assert rejected, f"{command} is not in {hat.profile.name}'s table; got {reply.raw!r}"
        else:
            _expect_runs(hat, motor_port, command, other)
        return
    token = shortest_resolving_prefix(command, table)
    _expect_runs(hat, motor_port, token, command)
    shorter = token[:-1]
    if shorter:
        # One character less must not run this command: it is someone else's, or nothing.
        owner = resolve(shorter, table)
        assert owner != command, \
            f"`{shorter}` must not resolve to {command} (its shortest prefix is `{token}`)"
        if owner is None:
            _expect_error(hat, shorter)
        else:
            _expect_runs(hat, motor_port, shorter, owner)


@pytest.mark.req("SYN-ABBREV", "FW-ABBREV-ORDER")
@pytest.mark.parametrize("prefix", ALL_AMBIGUOUS)
def test_ambiguous_prefix_resolves_by_table_order(hat: HatUnderTest, motor_port: int, verdict: Verdict,
                                                  prefix: str) -> None:
    table = hat.commands
    names = [c for c in table if c.startswith(prefix)]
    first = resolve(prefix, table)
    if first is None:
        _expect_error(hat, prefix)
        return
    out = probe(hat, motor_port, first, prefix)
    if len(names) < 2 or prefix in names:
        # Unique here, or the full name of a command: the document is satisfied by running it.
        assert out.ran, f"sent `{prefix}`: expected it to run {first}; came {out.seen}"
        return
    # The document says nothing about ambiguous prefixes: an observation, not a verdict on the
    # document, but it must be what the facts say this release does (FW-ABBREV-ORDER).
    assert out.ran, (f"`{prefix}` (prefix of {', '.join(names)}) should run {first}, the earliest in "
                     f"the table (docs/FIRMWARE-BEHAVIOUR.md#fb-matching); came {out.seen}")
    verdict.inform(f"`{prefix}` is a prefix of {', '.join(names)}: the document leaves it open; "
                   f"{hat.profile.name} runs {first}, the earliest in its table")


@pytest.mark.req("SYN-ABBREV")
@pytest.mark.parametrize("command", [c for c in DOCUMENT_COMMANDS])
def test_document_unique_prefix_runs_the_command(hat: HatUnderTest, motor_port: int, verdict: Verdict,
                                                 command: str) -> None:
    token = unique_prefix(command, DOCUMENT_COMMANDS) or command
    table = hat.commands
    if command not in table:
        reply = hat.exchange(f"{token} 0.2")
        verdict.document(False, key="BIAS-REMOVED", firmware_ok=reply.raw == b"\r\nError\r\n",
                         seen=f"`{token} 0.2` -> {reply.raw!r}")
        return
    _expect_runs(hat, motor_port, token, command)


@pytest.mark.req("SYN-ABBREV", "FW-MATCH-LONGER")
@pytest.mark.parametrize("command", ALL_COMMANDS)
def test_token_longer_than_a_name_is_an_error(hat: HatUnderTest, command: str) -> None:
    table = hat.commands
    token = next(command + x for x in "xz9_" if resolve(command + x, table) is None)
    _expect_error(hat, token)


@pytest.mark.req("SYN-ABBREV", "FW-MATCH-CASE")
@pytest.mark.parametrize("token", ["HELP", "Vin", "LIST", "VERSION", "Port 1", "V", "L", "SIG"])
def test_matching_is_case_sensitive(hat: HatUnderTest, token: str) -> None:
    _expect_error(hat, token)


@pytest.mark.req("SYN-ABBREV", "FW-MATCH-WRITE2")
def test_write2_must_be_typed_in_full(hat: HatUnderTest, motor_port: int) -> None:
    # Every shorter prefix of write2 is write1's (docs/FIRMWARE-BEHAVIOUR.md#fb-ambiguous):
    # `write 44 11 22` is write1.
    for n in range(1, len("write2")):
        assert resolve("write2"[:n], hat.commands) == "write1", \
            f"`{'write2'[:n]}` must be write1's in {hat.profile.name}'s table " \
            "(docs/FIRMWARE-BEHAVIOUR.md#fb-matching)"
    _expect_runs(hat, motor_port, "write", "write1")
    _expect_runs(hat, motor_port, "write2", "write2")

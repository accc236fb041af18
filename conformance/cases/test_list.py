"""CMD-LIST*: the `list` dump, checked against a grammar for the whole output and, for every
device present, against its devices.json catalogue entry (layout:
docs/FIRMWARE-BEHAVIOUR.md#fb-list)."""
from __future__ import annotations

import pytest

from ...protocol.devices import active_type_ids, catalogue
from ..hat_under_test import HatUnderTest
from ..mismatch import same
from ..needs import PortNeeds
from ..oracles.listing import parse_list, render_active, render_port
from ..verdict import UnknownBuild

APPENDIX_C = [0x25, 0x26, 0x2E, 0x2F, 0x30, 0x31, 0x3D, 0x3E, 0x3F, 0x40, 0x41]


def dump(hat: HatUnderTest) -> list:
    return hat.exchange_quiet("list", attempts=3).list_lines()


@pytest.mark.req("CMD-LIST", "DEV-PORTS")
def test_list_dump_follows_the_grammar_and_the_catalogue(hat: HatUnderTest) -> None:
    lines = dump(hat)
    entries = parse_list(lines)          # raises ListError naming the line that breaks the grammar
    for entry in entries:
        if entry.kind == "active":
            assert entry.lines == render_active(entry.port, catalogue()[f"0x{entry.id:02X}"]), \
                f"P{entry.port}: the block differs from the catalogue entry of 0x{entry.id:02X}"
        elif entry.kind == "passive":
            assert entry.id is not None and 1 <= entry.id <= 11, \
                f"P{entry.port}: expected a passive ID 1..11 (docs/FIRMWARE-BEHAVIOUR.md#fb-passive), " \
                f"came {entry.lines}"


@pytest.mark.req("CMD-LIST-EMPTY")
def test_empty_port_says_no_device_detected(hat: HatUnderTest, empty_port: int) -> None:
    entries = parse_list(dump(hat))
    assert entries[empty_port].lines == [f"P{empty_port}: no device detected"], \
        f"sent `list`: expected `P{empty_port}: no device detected`, came {entries[empty_port].lines}"


@pytest.mark.req("CMD-LIST", "CMD-LIST-EMPTY", "FW-LIST-EMPTY-HAT")
def test_list_of_an_empty_hat_appendix_a(hat: HatUnderTest, world: PortNeeds) -> None:
    world.require("unplug", "unplugging every device")
    for port in range(4):
        world.unplug(port)
    raw = hat.exchange_quiet("list").raw
    same(raw, b"\r\n" + b"".join(f"P{p}: no device detected\r\n".encode() for p in range(4)),
         "the worked example of an empty HAT (docs/FIRMWARE-BEHAVIOUR.md#fb-vectors)", sent="list")


@pytest.mark.req("CMD-LIST-PASSIVE", "ID-PASSIVE")
@pytest.mark.parametrize("ident", range(1, 12))
def test_passive_device_is_listed_by_its_id(hat: HatUnderTest, world: PortNeeds, ident: int) -> None:
    port = world.passive(ident)
    key = "passive_port_reset_each_scan"
    unknown = hat.undecided(key)         # an unknown build between R1 and R2: either behaviour
    if ident == 5 and unknown is None and hat.feature(key):
        # R1 rescans a button continuously and clears the port at each scan start, so `list`
        # practically never shows it (docs/FIRMWARE-BEHAVIOUR.md#fb-r1-passive); the connect line is
        # what identifies it.
        hat.expect(lambda e: e.text == f"P{port}: connected to passive ID 5", 1000)
        return
    expected = [f"P{port}: connected to passive ID {ident}"]
    entry = world.settled_entry(port, ("passive", ident))
    if ident == 5 and unknown is not None and entry.lines != expected:
        # Judged by the document; R1's behaviour (a button practically never listed) is no
        # fault of a build that may be R1's.
        raise UnknownBuild(f"{unknown}: `list` shows {entry.lines}, as R1 does")
    assert entry.lines == expected, f"sent `list`: expected {expected}, came {entry.lines}"


@pytest.mark.req("CMD-LIST-ACTIVE", "CMD-LIST-MODE", "ID-ACTIVE", "DEV-MODES")
@pytest.mark.parametrize("type_id", active_type_ids(), ids=lambda t: f"0x{t:02X}")
def test_active_device_block_matches_the_catalogue(hat: HatUnderTest, world: PortNeeds, type_id: int) -> None:
    port = world.active(type_id)
    entry = parse_list(dump(hat))[port]
    device = catalogue()[f"0x{type_id:02X}"]
    assert entry.kind == "active" and entry.id == type_id, \
        f"sent `list`: expected active ID {type_id:02X} on port {port}, came {entry.lines[:1]}"
    same("\r\n".join(entry.lines).encode(), "\r\n".join(render_active(port, device)).encode(),
         f"the catalogue's block of 0x{type_id:02X} (protocol/devices.json)")
    # DEV-MODES: at most 16 modes, numbered 0..15, as the document says.
    assert len(entry.modes) <= 16 and all(0 <= m.index <= 15 for m in entry.modes), \
        f"DEV-MODES: expected at most 16 modes numbered 0..15, came {[m.index for m in entry.modes]}"
    types = [m["format"]["type"] for m in device["modes"] if m["name"]]
    assert [m.type for m in entry.modes] == types, \
        f"expected the catalogue's mode types {types}, came {[m.type for m in entry.modes]}"
    if type_id in APPENDIX_C:
        assert entry.lines[0] == f"P{port}: connected to active ID {type_id:02X}", \
            f"expected the header of Appendix C, `P{port}: connected to active ID {type_id:02X}`; " \
            f"came {entry.lines[0]!r}"


@pytest.mark.req("CMD-LIST", "FW-LIST-PORT-LINES")
def test_every_port_entry_matches_what_is_there(hat: HatUnderTest) -> None:
    entries = parse_list(dump(hat))
    for entry in entries:
        spec = None if entry.kind == "empty" else (entry.kind, entry.id)
        want = render_port(entry.port, spec, catalogue())
        same("\r\n".join(entry.lines).encode(), "\r\n".join(want).encode(),
             f"port {entry.port}'s block as the catalogue gives it (protocol/devices.json)")

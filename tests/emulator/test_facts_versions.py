"""FIRMWARE-FACTS §11 "Differences between versions": every row checked on all seven profiles,
with the expectation written per column as the table gives it (not read from profiles.json).

Rows an existing test already checks on every profile are listed in tests/FACTS-COVERAGE.md;
the rows here are the ones whose existing tests run on some profiles only, plus the two rows
(PID deadzone, PV unwrap initialisation) whose existing tests are unit-level.
"""
from __future__ import annotations

from typing import List, Tuple

import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.protocol.profiles import load_profiles

ALL = [p.name for p in load_profiles().values()]
pytestmark = pytest.mark.req("FW-11")
EMPTY = {0: None, 1: None, 2: None, 3: None}

# §11 columns, quoted: R1 | R2 | R3 | R4 | R5 | R6/R7
DISCONNECTED_LINE = {"R1": False, "R2": True, "R3": True, "R4": True, "R5": True, "R6": True, "R7": True}
PASSIVE_REPEATS = {"R1": True, "R2": False, "R3": False, "R4": False, "R5": False, "R6": False,
                   "R7": False}
BUTTON_EVENTS = dict(DISCONNECTED_LINE)          # "Button pressed/released | no | yes | yes ..."
MATRIX_AUTOPOWER = {"R1": False, "R2": False, "R3": False, "R4": True, "R5": False, "R6": True,
                    "R7": True}
PLIMIT_PER_PORT = {"R1": False, "R2": False, "R3": False, "R4": False, "R5": False, "R6": True,
                   "R7": True}
COMBI_CLEARS = {"R1": False, "R2": False, "R3": False, "R4": False, "R5": True, "R6": True,
                "R7": True}
PID_DEADZONE_PARAM = dict(PLIMIT_PER_PORT)       # "fixed ±0.01" R1–R5, "parameter" R6+
UNWRAP_FROM_FIRST_SAMPLE = dict(PLIMIT_PER_PORT)  # "from 0 (last=0)" R1–R5, "first sample" R6+
# §5 / §10 passive scan: 8 × 10 ms (R1/R2) or 10 + 8×(1+10) = 98 ms (R3+), 6 matching scans;
# §4.2 empty-port cycle: about 180 ms (R1), 80 ms (R2), 98 ms (R3+)
SCAN_MS = {"R1": 80, "R2": 80, "R3": 98, "R4": 98, "R5": 98, "R6": 98, "R7": 98}
EMPTY_CYCLE_MS = {"R1": 180, "R2": 80, "R3": 98, "R4": 98, "R5": 98, "R6": 98, "R7": 98}


class Run:
    """An emulator with its output split into timed lines."""

    def __init__(self, profile: str, devices=None):
        self.emu = Emulator(firmware=profile, devices=devices or EMPTY)
        self.emu.boot()
        self.lines: List[Tuple[int, bytes]] = []
        self._buf = b""
        self.run(0)
        self.lines.clear()              # the start-up and connect output is not looked at here

    def run(self, ms: int) -> None:
        for _ in range(ms + 1):
            self._buf += self.emu.read()
            while b"\r\n" in self._buf:
                line, self._buf = self._buf.split(b"\r\n", 1)
                self.lines.append((self.emu.now, line))
            if ms == 0:
                return
            self.emu.advance(1)
            ms -= 1

    def send(self, text: str) -> int:
        self.emu.write(text.encode("ascii") + b"\r")
        return self.emu.now

    def times(self, line: bytes, since: int = 0) -> List[int]:
        return [t for t, x in self.lines if x == line and t >= since]


@pytest.mark.parametrize("profile", ALL)
def test_passive_rows(profile):
    # §11 `disconnected` line, `connected to passive ID` repeats, passive scan timing (§5, §10)
    r = Run(profile)
    t_plug = r.emu.now
    r.emu.world("@plug 2 passive 1")
    r.run(1500)
    connects = r.times(b"P2: connected to passive ID 1")
    first = connects[0] - t_plug
    assert 6 * SCAN_MS[profile] <= first <= 6 * SCAN_MS[profile] + EMPTY_CYCLE_MS[profile] + 1, first
    if PASSIVE_REPEATS[profile]:
        assert len(connects) >= 4        # "repeated after every scan (≈180 ms)"
    else:
        assert len(connects) == 1
    t_unplug = r.emu.now
    r.emu.world("@unplug 2")
    r.run(600)
    gone = r.times(b"P2: disconnected", t_unplug)
    assert len(gone) == (1 if DISCONNECTED_LINE[profile] else 0)


@pytest.mark.parametrize("profile", ALL)
def test_active_disconnect_row(profile):
    # §5: `P<p>: timeout during data phase: disconnecting`, then (R2+) `P<p>: disconnected`
    r = Run(profile, {0: "0x30", 1: None, 2: None, 3: None})
    t = r.emu.now
    r.emu.world("@unplug 0")
    r.run(700)
    lines = [x for tt, x in r.lines if tt >= t]
    expected = [b"P0: timeout during data phase: disconnecting"]
    if DISCONNECTED_LINE[profile]:
        expected.append(b"P0: disconnected")
    assert lines == expected


@pytest.mark.parametrize("profile", ALL)
def test_button_row(profile):
    r = Run(profile, {0: None, 1: "passive 5", 2: None, 3: None})
    r.run(300)
    t = r.emu.now
    r.emu.world("@button 1 1")
    r.run(300)
    r.emu.world("@button 1 0")
    r.run(300)
    events = [x for tt, x in r.lines if tt >= t and b"button" in x]
    assert events == ([b"P1: button pressed", b"P1: button released"] if BUTTON_EVENTS[profile] else [])


@pytest.mark.parametrize("profile", ALL)
def test_led_matrix_autopower_row(profile):
    # §7.1: constant setpoint 1.0 and coast cleared when the 0x40 is established (R4, R6, R7)
    r = Run(profile, {0: None, 1: "0x40", 2: None, 3: None})
    r.run(20)
    assert (r.emu.hat.controllers[1].generator.a == 1.0) is MATRIX_AUTOPOWER[profile]


@pytest.mark.parametrize("profile", ALL)
def test_plimit_scope_row(profile):
    # §11 `plimit` scope: "global, persistent" (R1–R5) / "per port, reset to 0.1 on every port reset"
    r = Run(profile)
    r.send("plimit 1")
    r.run(400)                             # several empty-port resets
    limits = [c.drive.limit for c in r.emu.hat.controllers]
    assert limits == ([6554] * 4 if PLIMIT_PER_PORT[profile] else [65536] * 4)


@pytest.mark.parametrize("profile", ALL)
def test_combi_clears_selection_row(profile):
    r = Run(profile, {0: None, 1: None, 2: None, 3: "0x30"})
    r.send("port 3 ; select 1")
    r.run(300)
    assert r.times(b"P3M1:  0")
    t = r.send("combi 1")
    r.run(400)
    reports = [x for tt, x in r.lines if tt > t and x.startswith(b"P3M1:")]
    assert (reports == []) is COMBI_CLEARS[profile]


@pytest.mark.parametrize("profile", ALL)
def test_pid_deadzone_row(profile):
    # PV = 5 (s4) × 0.001 = 0.005, SP = 0: e = 0.005. R1–R5: "e := 0 if −0.01 < e < 0.01";
    # R6+ with deadzone 0: |e| < 0 is false, so e stays. §7.4 `e=` is printed with §6.3.
    r = Run(profile, {0: None, 1: None, 2: None, 3: "0x30"})
    r.emu.world("@data 3 2 05 00 00 00")
    deadzone = " 0" if PID_DEADZONE_PARAM[profile] else ""
    t = r.send(f"port 3 ; select 2 ; pid 3 2 0 s4 0.001 0 0 0 0 0{deadzone} ; debug 16")
    r.run(100)
    lines = [x for tt, x in r.lines if tt >= t and x.startswith(b"P3: pv=")]
    assert lines
    e = b"e=5.00000E-3 " if PID_DEADZONE_PARAM[profile] else b"e=0.00000 "
    assert all(x.startswith(b"P3: pv=5.00000E-3 sp=0.00000: " + e) for x in lines), lines[0]
    if PID_DEADZONE_PARAM[profile]:        # a deadzone of 0.01 zeroes it as well
        t = r.send("pid 3 2 0 s4 0.001 0 0 0 0 0 0.01")
        r.run(50)
        later = [x for tt, x in r.lines if tt > t and x.startswith(b"P3: pv=")]
        assert later and all(b" e=0.00000 " in x for x in later)


@pytest.mark.parametrize("profile", ALL)
def test_pv_unwrap_initialisation_row(profile):
    # §7.2 with U = 360 and a first reading of 300: R1–R5 start from last = 0, so
    # d = 300 > 180 → d −= 360 → PV = −60; R6+ take the first sample: PV = 300.
    r = Run(profile, {0: None, 1: None, 2: None, 3: "0x30"})
    r.emu.world("@data 3 2 2C 01 00 00")
    deadzone = " 0" if PID_DEADZONE_PARAM[profile] else ""
    t = r.send(f"port 3 ; select 2 ; pid 3 2 0 s4 1 360 0 0 0 0{deadzone} ; debug 16")
    r.run(100)
    lines = [x for tt, x in r.lines if tt >= t and x.startswith(b"P3: pv=")]
    pv = b"P3: pv=300.000 " if UNWRAP_FROM_FIRST_SAMPLE[profile] else b"P3: pv=-60.0000 "
    assert lines and all(x.startswith(pv) for x in lines), lines[0]


@pytest.mark.parametrize("profile", [p for p in ALL if BUTTON_EVENTS[p]])
def test_button_state_survives_a_disconnect(profile):
    # §5: "Printed when the pressed state changes ... The stored state is not cleared on
    # disconnect." Unplugged while pressed; a released button plugged in again reports
    # `released` right after `connected`.
    r = Run(profile, {0: None, 1: None, 2: "passive 5", 3: None})
    r.emu.world("@button 2 1")
    r.run(300)
    r.emu.world("@unplug 2")
    r.run(500)
    r.emu.world("@plug 2 passive 5")
    r.run(1000)
    assert [x for _, x in r.lines] == [b"P2: button pressed", b"P2: disconnected",
                                       b"P2: connected to passive ID 5", b"P2: button released"]


@pytest.mark.parametrize("profile", ALL)
def test_debug_4_signature_lines_and_empty_port_cycle(profile):
    # §7.4 bit 4: `P<p>: D5 signature=XXXX id=<dec>` every scan on every port; §4.2: an empty
    # port passes state 0 "about every 180 ms on R1, 80 ms on R2 and 98 ms on R3+".
    r = Run(profile)
    r.send("debug 4")
    r.run(1000)
    lines = [(t, x) for t, x in r.lines if x.startswith(b"P3: D5 ")]
    assert lines and all(x.startswith(b"P3: D5 signature=") and x.endswith(b" id=0") and
                         len(x.split(b"signature=")[1].split(b" ")[0]) == 4 for _, x in lines)
    gaps = {b[0] - a[0] for a, b in zip(lines, lines[1:])}
    assert all(abs(g - EMPTY_CYCLE_MS[profile]) <= 2 for g in gaps), gaps


@pytest.mark.parametrize("profile", ALL)
def test_setup_timeout_line(profile):
    # §5 "Active devices" 2: `P<p>: timeout during setup phase: disconnecting` (more than
    # 2000 ms with no message); no `disconnected`, since it never connected.
    r = Run(profile)
    r.emu.world("@plug 0 0x3D")
    r.run(600)
    assert r.times(b"P0: connecting to active device")
    t = r.emu.now
    r.emu.world("@unplug 0")
    r.run(2300)
    after = [x for tt, x in r.lines if tt > t]
    assert after == [b"P0: timeout during setup phase: disconnecting"]

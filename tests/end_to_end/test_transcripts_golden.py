"""Golden transcripts (transcripts/): reviewed against FIRMWARE-FACTS, replayed on the emulator.

Three kinds of check, each able to fail on its own:
1. review: the facts' exact strings and rules, checked in the golden files themselves (a golden
   file is only as good as its review; these expectations come from FIRMWARE-FACTS, not from
   the emulator);
2. replay: every golden replayed on the in-process emulator of its release matches exactly;
3. profiles: replayed on another release, the diff is exactly the documented differences.
"""
from __future__ import annotations

import pathlib
import re
from typing import Tuple

import pytest
from repo_paths import REPO

from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.transcript import read_transcript
from buildhat_conformance.transcripts.compare import Difference, RuleSet
from buildhat_conformance.transcripts.replay import compare_transcripts, plan_replay, replay

GOLDEN = REPO / "transcripts" / "data"
R7, R4 = "1737564117", "1670332907"
R7_VERSION = "Firmware version: 1737564117 2025-01-22T16:41:57+00:00"
R4_VERSION = "Firmware version: 1670332907 2022-12-06T13:21:47+00:00"
FILES = sorted(GOLDEN.glob("*.jsonl"))


def load(name: str):
    return read_transcript(str(GOLDEN / name))


def after_host(t, text: str) -> bytes:
    """The HAT's answer to host line ``text``: its bytes in the same millisecond (TRANSCRIPT.md:
    an answer shares the time of the host event), up to the next host event."""
    out, on, when = bytearray(), False, None
    for e in t.events:
        if e.get("dir") == "host":
            if on:
                break
            on, when = e["bytes"] == text, e["t"]
        elif on and e.get("dir") == "hat" and e["t"] == when:
            out += (e["line"] + "\r\n").encode() if "line" in e else e["partial"].encode()
    assert on or out, f"host line {text!r} not in the transcript"
    return bytes(out)


def dev_after_host(t, text: str) -> list:
    frames, on = [], False
    for e in t.events:
        if e.get("dir") == "host":
            if on:
                break
            on = e["bytes"] == text
        elif on and e.get("dir") == "dev":
            frames.append(e["hex"])
    return frames


def firmware_of(path: pathlib.Path) -> str:
    return read_transcript(str(path)).meta["firmware"].split()[0]


# -- 1. review against FIRMWARE-FACTS ----------------------------------------------------------
def test_every_golden_has_its_script_and_a_readme_entry():
    readme = (GOLDEN / "README.md").read_text(encoding="utf-8")
    assert FILES
    for f in FILES:
        t = read_transcript(str(f))
        script = GOLDEN / t.meta["script"]
        assert script.is_file(), f"{f.name}: meta.script {t.meta['script']} is not beside it"
        assert f.name in readme, f"{f.name} is not described in transcripts/data/README.md"
        assert t.events[-1]["dir"] == "end"


def test_abbreviation_facts():
    t = load("abbreviation.jsonl")
    assert after_host(t, "echo 1\r") == b"\r\nP0>"
    assert after_host(t, "p 2\r") == b"p 2\r\nP2>"
    assert after_host(t, "c\r") == b"c\r\nP2>"                        # clear_faults: no output
    assert after_host(t, "v\r") == b"v\r\n8.00 V\r\nP1>"              # v -> vin (not version)
    assert after_host(t, "ve\r") == b"ve\r\n" + R7_VERSION.encode() + b"\r\nP1>"
    assert dev_after_host(t, "w 40\r") == ["40 00 BF"]                 # w -> write1, one pad byte
    assert dev_after_host(t, "write 40\r") == ["40 00 BF"]
    assert dev_after_host(t, "write2 44 11 22\r") == ["44 11 22 88"]
    assert dev_after_host(t, "sel 0\r") == ["46 00 B9", "43 00 BC"]
    assert dev_after_host(t, "selo 0\r") == []                         # R5+: same mode, no SELECT
    assert after_host(t, "b .4\r") == b"b .4\r\nError\r\nP1>"          # R6+: no bias
    for bad in ("ports\r", "vinx\r", "VIN\r", "e\r"):
        assert after_host(t, bad) == bad[:-1].encode() + b"\r\nError\r\nP1>"
    assert after_host(t, "echo 0\r") == b"echo 0\r\n"                 # no prompt once echo is off


def test_separators_facts():
    t = load("separators.jsonl")
    assert after_host(t, "port 1 vin\r") == b"\r\n8.00 V\r\n"          # no ';' needed
    assert after_host(t, "set;0.25\r") == b"\r\n"
    assert after_host(t, "port 0 ; vin ;; vin\r") == b"\r\n8.00 V\r\n8.00 V\r\n"
    for line in ("port 1x\r", "port 1.5\r", "set 0.5 0.3\r", "p -1\r", "vin\n\r", "\tvin\r",
                 "set t 0 1 1e3 0\r"):
        assert after_host(t, line) == b"\r\nError\r\n", line
    assert after_host(t, "p 9\r") == b"\r\n"
    assert after_host(t, "vin\r\n") == b"\r\n8.00 V\r\n"
    assert after_host(t, "vin\r") == b"\r\nError\r\n"                  # the LF began this line
    assert after_host(t, "# comment\r") == b"\r\n"                      # R6+: ignored, no Error


def test_list_format_facts():
    out = after_host(load("list-format.jsonl"), "list\r").decode().split("\r\n")
    assert out[0] == "" and out[1:3] == ["P0: connected to active ID 30", "type 30"]
    assert "P1: connected to active ID 3D" in out and "type 3D" in out
    assert "P2: connected to passive ID 8" in out and out[-2:] == ["P3: no device detected", ""]
    assert "  M9 CALIB SI = " in out                                    # trailing space kept
    for line in out:
        if "PID:" in line:
            assert re.fullmatch(r"(     speed|  position) PID:( [0-9A-F]{8}){4}", line), line
        if "RAW:" in line:
            assert re.fullmatch(r"    RAW: [0-9A-F]{8} [0-9A-F]{8}    PCT: [0-9A-F]{8} [0-9A-F]{8}    "
                                r"SI: [0-9A-F]{8} [0-9A-F]{8}", line), line


def test_fault_latching_facts():
    t = load("fault-latching.jsonl")
    lines = [(e["t"], e["line"]) for e in t.events if e.get("dir") == "hat" and "line" in e and e["t"] >= 0]
    motor = [tt for tt, s in lines if s == "Motor power fault"]
    port = [tt for tt, s in lines if s == "Port power fault"]
    clear = next(e["t"] for e in t.events if e.get("bytes") == "clear_faults\r")
    # §5: >10 ms deglitch, dump, 1000 ms hold-off (period ~1011 ms), latched until clear_faults
    assert 10 < motor[0] <= 20 and len(motor) >= 3
    assert all(1000 < b - a <= 1030 for a, b in zip(motor, motor[1:]))
    assert motor[-1] < clear and all(tt < clear for tt in motor)
    i = [s for _t, s in lines].index("Motor power fault")
    assert [s for _t, s in lines][i + 1:i + 6] == [" Port 4D 4E 4F", "   0  01 00 00", "   1  00 00 00",
                                                  "   2  00 00 00", "   3  00 00 00"]
    # the port fault: at once after the deglitch, then 1 Hz, and only while asserted
    assert len(port) == 2 and 990 <= port[1] - port[0] <= 1010


PID_RE = re.compile(r"P0: pv=(\S+) sp=(\S+): e=(\S+) ie=(\S+) de=(\S+) cv=(\S+)")


def test_pid_debug16_follows_the_control_law():
    """§7.2 control law, recomputed here from each line's own pv/sp (Kp 5, Ki 0.5, Kd 0.1,
    windup 3, deadzone 0.01): e = pv - sp (0 inside the deadzone), ie += e*0.01, de = (e - e')/0.01,
    cv = -(Kp e + Ki ie + Kd de). The float printer keeps 6 digits, hence the tolerances."""
    t = load("pid-debug16.jsonl")
    rows = [[float(x) for x in PID_RE.fullmatch(e["line"]).groups()]
            for e in t.events if e.get("dir") == "hat" and e.get("line", "").startswith("P0: pv=")]
    assert len(rows) > 60
    prev_e, prev_ie = None, None
    for pv, sp, e, ie, de, cv in rows:
        want_e = 0.0 if abs(pv - sp) < 0.01 else pv - sp
        assert e == pytest.approx(want_e, rel=1e-4, abs=2e-6)
        if prev_e is not None and prev_ie is not None:
            assert ie == pytest.approx(max(-3, min(3, prev_ie + e * 0.01)), rel=1e-4, abs=2e-6)
            assert de == pytest.approx((e - prev_e) / 0.01, rel=1e-3, abs=1e-3)
        assert cv == pytest.approx(-(5 * e + 0.5 * ie + 0.1 * de), rel=1e-4, abs=2e-5)
        prev_e, prev_ie = e, ie
    assert {r[1] for r in rows} == {0.0, -0.25}
    assert abs(rows[-1][0] - -0.25) < 0.02   # the loop settled near the last set-point


def test_waveform_timing_facts():
    t = load("waveform-timing.jsonl")
    sent = {e["bytes"]: e["t"] for e in t.events if e.get("dir") == "host"}
    done = {e["line"]: e["t"] for e in t.events if e.get("dir") == "hat" and "done" in e.get("line", "")}
    # §7.1: T = 0.2 s ends on the 20th tick, T = 0.3 s on the 30th; the first tick is 0-10 ms after
    # the command, so the end is 190-200 (290-300) ms after it
    assert 190 <= done["P0: pulse done"] - sent["set pulse 0.5 0 0.2 0\r"] <= 200
    assert 290 <= done["P0: ramp done"] - sent["set ramp 0 1 0.3 0\r"] <= 300
    sps = [(e["t"], float(PID_RE.fullmatch(e["line"]).group(2))) for e in t.events
           if e.get("dir") == "hat" and e.get("line", "").startswith("P0: pv=")]
    square = [sp for tt, sp in sps if sent["pid 0 0 5 s2 0.0027777778 1 0 0 0 3 0 ; debug 16 ; "
                                                "set square 0 1 0.1 0\r"] < tt < 300]
    assert set(square) == {0.0, 1.0}
    assert all(-1 <= sp <= 1 for tt, sp in sps if 300 < tt < 550)     # triangle -1..1


def test_appendix_a_frames_and_document_differences():
    dist = load("appendix-a-distance.jsonl")
    assert "D5 10 20 30 40 6A" in dev_after_host(dist, "select 5 ; write1 c5 10 20 30 40\r")
    matrix = load("appendix-a-matrix.jsonl")
    assert dev_after_host(matrix, "select 0 ; write1 c0 5\r")[-1] == "C0 05 3A"
    assert dev_after_host(matrix, "select 2 ; write1 c2 12 23 34 45 12 23 34 45 12\r")[-1] == \
        "E2 12 23 34 45 12 23 34 45 12 00 00 00 00 00 00 00 0F"
    motor7, motor4 = load("appendix-a-motor.jsonl"), load("appendix-a-motor.1670332907.jsonl")
    assert dev_after_host(motor7, "port 0 combi 0 1 0 2 0 3 0\r") == ["5C 23 00 10 20 30 00 00 00 80"]
    # §12 items 7 and 8: the document's bias and 10-number pid fail on R6+, work on R1-R5
    for line in ("plimit 1; bias .4\r", "pid 0 0 5 s2 0.0027777778 1 5 0 .1 3\r"):
        assert after_host(motor7, line) == b"\r\nError\r\n"
        assert after_host(motor4, line) == b"\r\n"


# -- 2. replay on the emulator ----------------------------------------------------------------
@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_golden_replays_exactly_on_its_release(path):
    recorded = read_transcript(str(path))
    plan = plan_replay(recorded, str(path))
    target = make_target(f"inprocess:{firmware_of(path)}", devices=plan.layout)
    actual, _slack, remarks = replay(recorded, target, plan)
    # Lines exact; times within 2 ms: the in-process target's controller tick and device timers
    # run a millisecond or two out of phase with script mode's (reported; not a protocol matter).
    result = compare_transcripts(recorded, actual, RuleSet(timing_ms=2))
    assert result.ok, result.render()
    assert result.compared >= 3 and not remarks


# -- 3. the documented differences on another release ------------------------------------------
def seen(d: Difference) -> Tuple[str, bytes]:
    """A difference as its line's text and the host line it answered (every one here follows one)."""
    unit = d.expected or d.actual
    assert unit is not None and unit.after is not None, d
    return unit.text, unit.after[1]


def diff_on(name: str, release: str, rules: RuleSet):
    recorded = load(name)
    plan = plan_replay(recorded, str(GOLDEN / name))
    actual, _s, _r = replay(recorded, make_target(f"inprocess:{release}", devices=plan.layout), plan)
    return compare_transcripts(recorded, actual, rules)


def test_abbreviation_on_r4_differs_exactly_as_documented():
    c = diff_on("abbreviation.jsonl", R4, RuleSet())
    got = [(d.kind, *seen(d)) for d in c.differences]
    # FIRMWARE-FACTS §0/§11: R4 has bias, no selrate / pwmparams / port_plimit, and its own version.
    assert got == [
        ("changed", R7_VERSION, b"ve\r"),
        ("missing", "Error", b"b .4\r"),
        ("extra", "Error", b"selr 5\r"),
        ("extra", "Error", b"pwmp 0 0\r"),
        ("extra", "Error", b"port_ 0.5\r"),
    ], c.render()
    assert c.differences[0].actual.text == R4_VERSION


def test_appendix_a_motor_on_r4_differs_by_the_two_documented_errors():
    # the motor moves differently once R4 accepts the pid, so data lines are left out here
    c = diff_on("appendix-a-motor.jsonl", R4, RuleSet.from_options(["data=ignore"]))
    got = [(d.kind, *seen(d)) for d in c.differences]
    assert got == [("missing", "Error", b"plimit 1; bias .4\r"),
                   ("missing", "Error", b"pid 0 0 5 s2 0.0027777778 1 5 0 .1 3\r")], c.render()


def test_replay_refuses_world_actions_a_target_cannot_do(tmp_path, capsys):
    from buildhat_conformance.cli import main

    rc = main(["replay", str(GOLDEN / "fault-latching.jsonl"), "--target", "loop://"])
    err = capsys.readouterr().err
    assert rc == 3 and "@motorfault" in err and "@portfault" in err and "--without-world" in err


def test_golden_replay_diff_is_readable():
    c = diff_on("separators.jsonl", R4, RuleSet())
    text = c.render(load("separators.jsonl").of("host"))
    assert "@@ t=0 ms, after host b'# comment\\r' at t=0 ms @@" in text
    assert "+ Error    [error: not in the recording, t=0 ms]" in text
    assert text.splitlines()[-1].startswith("DIFFER:") and text.splitlines()[-1].endswith(", 1 extra")

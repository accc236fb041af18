"""The bench's measurements, in small: the suite's wait accounting, the fuzz throughput paths
and the group runner. No timing is asserted (shared noisy machines): only that the figures
are computed from what really happened."""
from __future__ import annotations

import argparse
import json

from buildhat_conformance.bench import cli, host_write, suite, throughput
from buildhat_conformance.bench.figures import Figure
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target


def test_session_counts_the_waits_it_is_asked_for() -> None:
    s = Session(make_target("inprocess")).open()
    try:
        before = s.waited_hat_ms
        s.wait_ms(120)
        s.collect(0.05)                 # HAT seconds on a virtual-time target (scale 1)
        s.note_wait(30)
        s.wait_ms(0)
        s.command("vin")                # a round trip is overhead, not waiting
        assert s.waited_hat_ms - before == 200.0
    finally:
        s.close()


def test_parse_junit_sums_the_case_waits(tmp_path) -> None:
    path = tmp_path / "junit.xml"
    path.write_text(
        "<testsuites><testsuite name='s'>"
        "<testcase classname='a' name='x' time='1.0'><properties><property name='hat_wait_ms' value='250.5'/>"
        "</properties></testcase>"
        "<testcase classname='a' name='y' time='2.0'><properties><property name='hat_wait_ms' value='100'/>"
        "</properties><failure message='m'>m</failure></testcase>"
        "<testcase classname='a' name='z' time='0.5'><skipped message='s'/></testcase>"
        "</testsuite></testsuites>")
    res = suite.parse_junit(str(path))
    assert res == {"cases": 3, "failed": 1, "skipped": 1, "hat_wait_ms": 350.5, "case_s": 3.5}


def test_fuzz_figures_come_from_the_commands_own_summary() -> None:
    """The bench runs `buildhat-conformance fuzz` and takes what its summary prints."""
    res = throughput.fuzz_command("inprocess", seconds=1.0, extra=["--steps", "5"])
    assert res["lines"] > 0 and res["inputs"] > 0 and res["runs"] >= 1 and res["lines_per_s"] > 0
    assert res["findings"] == [] and res["note"] == ""
    assert "wire_share_pct" not in res          # in-process there is no wire


def test_parse_summary_reads_the_wire_share_and_findings() -> None:
    text = ("fuzz: 3 runs, 900 inputs (950 lines, 95 lines/s) in 10.0 s\n"
            "  wire: sent 1200 B/s, received 9400 B/s; the busier direction carries 82 % "
            "of what 115200 baud can\n"
            "  FINDING [fate] (reproduced 2/3): x\n")
    res = throughput.parse_summary(text)
    assert res["lines_per_s"] == 95 and res["wire_share_pct"] == 82 and res["findings"] == ["fate"]


def test_group_runs_are_capped_and_notes_kept(monkeypatch, tmp_path) -> None:
    calls = []

    def once() -> dict:
        calls.append(1)
        return {"k": 5.0, "note": "10 cases, 0 failed"}

    groups = [("slow", once, [(Figure("a", "s"), "k")], 1)]
    monkeypatch.setattr(cli, "_groups", lambda quick: groups)
    out = tmp_path / "bench.json"
    assert cli.main(argparse.Namespace(runs=3, quick=False, only="", output=str(out), profile=None)) == 0
    data = json.loads(out.read_text())
    assert len(calls) == 1 and data["figures"][0]["note"] == "10 cases, 0 failed"
    assert data["meta"]["loadavg"]


def test_host_write_figures_come_from_a_real_pty_and_the_wires_pace() -> None:
    """The bench's host-write group, small: the user's `buildhat-emulator --pty --baud 115200` and a pyserial
    host. Lower bounds only (a loaded machine is slower, never faster): the HAT answers no sooner than the
    upload's wire time, and a round trip takes at least its request's and answer's bytes on the wire."""
    payload = 6000                                   # 0.52 s at 115200 baud
    res = host_write.host_write(payload=payload)
    rate = host_write.BAUD / 10
    assert res["answer_s"] >= payload / rate, res
    assert 0 <= res["write_s"] <= res["flush_s"] <= res["answer_s"], res
    assert res["version_rtt_ms"] >= (len(b"version\r") + len(b"Firmware version: ")) / rate * 1000, res
    assert res["held_bytes"] == max(0.0, payload - res["write_s"] * rate)

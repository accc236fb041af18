"""The HTML report (conformance/report/) from hand-written JUnit files and transcripts."""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

import pytest

from buildhat_conformance.cli import main as cli_main
from buildhat_conformance.conformance.report import build_report
from buildhat_conformance.conformance.report import page as report_html
from buildhat_conformance.conformance.report.junit import check_junit, read_junit
from buildhat_conformance.conformance.report.requirement_coverage import coverage
from buildhat_conformance.conformance.report.series import ideal_setpoint, pid_series, wave_runs
from buildhat_conformance.protocol.requirements import requirement_ids

# The debug 16 example of FIRMWARE-FACTS §7.4 (Kp=5, Ki=0.5, Kd=0.1, SP=1).
PID_LINES = [
    "P0: pv=0.00000 sp=1.00000: e=-1.00000 ie=-0.0100000 de=-100.000 cv=15.0050",
    "P0: pv=0.100000 sp=1.00000: e=-0.900000 ie=-0.0190000 de=10.0000 cv=3.50950",
    "P0: pv=0.250000 sp=1.00000: e=-0.750000 ie=-0.0265000 de=15.0000 cv=2.26325",
    "P0: pv=0.500000 sp=1.00000: e=-0.500000 ie=-0.0315000 de=25.0000 cv=0.0157499",
    "P0: pv=0.995000 sp=1.00000: e=0.00000 ie=-0.0315000 de=50.0000 cv=-4.98425",
]


def write_transcript(path, events, firmware="1737564117"):
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(json.dumps({"dir": "meta", "firmware": firmware}) + "\n")
        for e in events:
            fh.write(json.dumps(e) + "\n")


def pid_transcript(path):
    cmd = "port 0 ; debug 16 ; pid 0 0 0 s1 1 0 5 0.5 0.1 3 0.01 ; set 1\r"
    evs = [{"t": 0, "dir": "host", "bytes": cmd},
           {"t": 0, "dir": "hat", "line": ""}]
    evs += [{"t": 10 * (i + 1), "dir": "hat", "line": line} for i, line in enumerate(PID_LINES)]
    write_transcript(path, evs)


def square_transcript(path):
    # A square wave 0..1, period 0.1 s, as debug 16 would show its sp every 10 ms from t=10.
    evs = [{"t": 0, "dir": "host", "bytes": "p 1 ; s sq 0 1 0.1 0\r"}, {"t": 0, "dir": "hat", "line": ""}]
    for k in range(1, 21):
        sp = "1.00000" if (k % 10) >= 5 else "0.00000"
        evs.append({"t": 10 * k, "dir": "hat",
                    "line": f"P1: pv=0.00000 sp={sp}: e=0.00000 ie=0.00000 de=0.00000 cv=0.00000"})
    write_transcript(path, evs)


def failing_transcript(path):
    write_transcript(path, [
        {"t": -300, "dir": "hat", "line": "Done initialising ports"},
        {"t": 0, "dir": "host", "bytes": "bias .4\r"},
        {"t": 0, "dir": "hat", "line": ""},
        {"t": 0, "dir": "hat", "line": "Error"},
        {"t": 20, "dir": "end"},
    ])


def junit_xml(cases, name="buildhat-conformance", target="emulator:1737564117", counts=None):
    """A JUnit file shaped like the suite's: one testsuite, per-case properties."""
    root = ET.Element("testsuites")
    fails = sum(1 for c in cases if c.get("failure"))
    skips = sum(1 for c in cases if c.get("skipped"))
    attrs = {"name": name, "tests": str(len(cases)), "failures": str(fails), "errors": "0",
             "skipped": str(skips), "time": "1.5", "timestamp": "2026-11-22T06:00:00"}
    attrs.update(counts or {})
    suite = ET.SubElement(root, "testsuite", attrs)
    for c in cases:
        tc = ET.SubElement(suite, "testcase", {"classname": c.get("classname", "conformance.test_x"),
                                               "name": c["name"], "time": "0.01"})
        props = ET.SubElement(tc, "properties")
        for key, value in [("target", target)] + c.get("props", []):
            ET.SubElement(props, "property", {"name": key, "value": value})
        if c.get("failure"):
            f = ET.SubElement(tc, "failure", {"message": c["failure"]})
            f.text = "assert b'Error' == b''"
        if c.get("skipped"):
            ET.SubElement(tc, "skipped", {"message": c["skipped"]})
    return ET.tostring(root, encoding="unicode")


@pytest.fixture()
def sample(tmp_path):
    pid_transcript(tmp_path / "pid.jsonl")
    square_transcript(tmp_path / "square.jsonl")
    failing_transcript(tmp_path / "bias.jsonl")
    r7 = [
        {"name": "test_vin_format", "props": [("req", "CMD-VIN"), ("firmware", "1737564117"),
                                              ("profile", "R7"), ("verdict", "pass")]},
        {"name": "test_abbrev_c", "props": [("req", "SYN-ABBREV"), ("verdict", "known deviation"),
                                            ("profile", "R7"), ("deviations", "ABBREV-AMBIGUOUS-RUNS")]},
        {"name": "test_bias", "failure": "bias answered Error", "props": [
            ("requirements", "CMD-BIAS, FW-11-BIAS"), ("profile", "R7"), ("transcript", "bias.jsonl")]},
        {"name": "test_pid_debug", "props": [("req", "CMD-PID-WINDUP"), ("req", "CMD-PID"),
                                             ("transcript", "pid.jsonl"), ("verdict", "informational")]},
        {"name": "test_square", "props": [("req", "CMD-SET-SQUARE"), ("transcript", "square.jsonl")]},
        {"name": "test_ledmode_rig", "skipped": "needs rig", "props": [("req", "CMD-LEDMODE")]},
    ]
    r4 = [{"name": "test_vin_format", "props": [("req", "CMD-VIN"), ("profile", "R4")]},
          {"name": "test_bias", "props": [("req", "CMD-BIAS"), ("profile", "R4")]}]
    (tmp_path / "r7.xml").write_text(junit_xml(r7), encoding="utf-8")
    (tmp_path / "r4.xml").write_text(junit_xml(r4, target="emulator:1670332907"), encoding="utf-8")
    return tmp_path


def test_junit_cases_carry_verdict_class_and_requirements(sample):
    run = read_junit(str(sample / "r7.xml"))
    by = {c.name: c for c in run.cases}
    assert by["test_vin_format"].verdict == "pass"
    assert by["test_abbrev_c"].verdict == "known_deviation"
    assert by["test_bias"].verdict == "fail" and by["test_bias"].message == "bias answered Error"
    assert by["test_bias"].requirements == ("CMD-BIAS", "FW-11-BIAS")
    assert by["test_pid_debug"].requirements == ("CMD-PID-WINDUP", "CMD-PID")
    assert by["test_ledmode_rig"].verdict == "skip"
    assert by["test_bias"].transcript == str(sample / "bias.jsonl")
    assert run.target == "emulator:1737564117" and run.profile == "R7"
    assert run.counts() == {"pass": 2, "fail": 1, "skip": 1, "known_deviation": 1, "informational": 1,
                            "target_fault": 0, "not_run": 0}
    assert run.problems == []


def test_junit_check_finds_what_ci_readers_trip_over(tmp_path):
    cases = [{"name": "a", "failure": "x"}, {"name": "b"}]
    good = tmp_path / "good.xml"
    good.write_text(junit_xml(cases), encoding="utf-8")
    assert check_junit(str(good)) == []
    wrong = tmp_path / "wrong.xml"
    wrong.write_text(junit_xml(cases, counts={"failures": "0", "tests": "3"}), encoding="utf-8")
    problems = check_junit(str(wrong))
    assert any("failures" in p for p in problems) and any("tests" in p for p in problems)
    two = tmp_path / "two.xml"
    two.write_text("<testsuites><testsuite name='a' tests='0'/><testsuite name='b' tests='0'/></testsuites>")
    assert any("2 <testsuite>" in p for p in check_junit(str(two)))
    broken = tmp_path / "broken.xml"
    broken.write_text("<testsuites><testsuite", encoding="utf-8")
    assert check_junit(str(broken))[0].startswith("not well-formed")


def test_coverage_has_every_requirement_and_marks_holes(sample):
    runs = [read_junit(str(sample / "r7.xml")), read_junit(str(sample / "r4.xml"))]
    cov = coverage(runs)
    assert [r.requirement.id for r in cov.rows] == requirement_ids()
    status = {r.requirement.id: r.status for r in cov.rows}
    assert status["CMD-VIN"] == "pass" and status["CMD-BIAS"] == "fail"
    assert status["SYN-ABBREV"] == "known_deviation" and status["CMD-LEDMODE"] == "untested"
    assert status["LINK-SERIAL"] == "hole"
    assert {r.requirement.id for r in cov.holes} == {i for i, s in status.items() if s == "hole"}
    assert list(cov.other_ids) == ["FW-11-BIAS"]
    vin = next(r for r in cov.rows if r.requirement.id == "CMD-VIN")
    assert vin.counts["pass"] == 2   # once per run


def _charts(text):
    return re.findall(r"<svg class=chart .*?</svg>", text)


def test_html_report_is_self_contained_and_complete(sample, monkeypatch):
    import buildhat_conformance.conformance.report as report

    monkeypatch.setattr(report, "MIN_SAMPLES", 1)   # the hand-made PID run has 5 samples
    out = sample / "out" / "index.html"
    build_report([str(sample / "r7.xml"), str(sample / "r4.xml")], str(out))
    text = out.read_text(encoding="utf-8")
    # no network: nothing fetched from anywhere, no scripts
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:|//)""", text, re.I)
    assert "<script" not in text.lower() and "<link" not in text.lower() and "@import" not in text
    for rid in requirement_ids():
        assert f'id="req-{rid}"' in text
    assert 'class="hole" id="req-LINK-SERIAL"' in text
    assert "emulator:1670332907" in text and "emulator:1737564117" in text
    # the failure shows the transcript around it, host and HAT side
    fail = text[text.index('id=failures'):text.index('id=deviations')]
    assert "test_bias" in fail and "bias answered Error" in fail
    assert "&gt; b&#x27;bias .4\\r&#x27;" in fail and "&lt; Error" in fail
    dev = text[text.index('id=deviations'):text.index('id=plots')]
    assert "test_abbrev_c" in dev and "test_bias" not in dev
    assert "<code>ABBREV-AMBIGUOUS-RUNS</code>" in dev and "1 kind(s)" in dev
    charts = _charts(text)
    assert len(charts) == 3   # square wave against its oracle, PID on P0, PID on P1
    [wave] = [c for c in charts if "set square" in c]
    [pid0] = [c for c in charts if "PID on P0" in c]
    assert "P1 set square 0 1 0.1 0" in wave and "oracle" in wave
    assert wave.count("<circle") == 20 + 1      # the 20 samples, and the legend's mark
    # PID: set-point and pv over cv, the ±1 clamp dashed; one path point per sample
    assert "PID on P0" in pid0 and pid0.count('stroke-dasharray') == 2
    paths = re.findall(r'<path d="([^"]*)"', pid0)
    assert len(paths) == 3 and all(p.count("M") == 1 for p in paths)
    assert len(re.findall(r"[MLHV]", paths[1])) == 5      # pv: 5 samples, straight segments


def test_plots_carry_their_numbers_in_words(sample, monkeypatch):
    import buildhat_conformance.conformance.report as report

    monkeypatch.setattr(report, "MIN_SAMPLES", 1)
    out = sample / "plain.html"
    report.build_report([str(sample / "r7.xml")], str(out))
    text = out.read_text(encoding="utf-8")
    assert "5 samples on P0" in text and "cv -4.98425 .. 15.005" in text


def test_runs_too_short_to_show_anything_are_not_plotted(sample):
    out = sample / "short.html"
    build_report([str(sample / "r7.xml")], str(out))   # default minimum: 10 samples
    text = out.read_text(encoding="utf-8")
    assert "PID on P0" not in text      # 5 samples
    assert "PID on P1" in text          # the square-wave run has 20


def test_pid_series_reads_debug_16_lines_exactly(sample):
    from buildhat_conformance.harness.transcript import iter_events

    s = pid_series(iter_events(str(sample / "pid.jsonl")))[0]
    assert s.t == [10, 20, 30, 40, 50]
    assert s.pv == [0.0, 0.1, 0.25, 0.5, 0.995]
    assert s.sp == [1.0] * 5
    assert s.cv == [15.005, 3.5095, 2.26325, 0.0157499, -4.98425]
    assert s.ie[-1] == -0.0315


def test_wave_runs_measure_against_the_ideal(sample):
    from buildhat_conformance.harness.transcript import iter_events

    [run] = wave_runs(iter_events(str(sample / "square.jsonl")))
    assert (run.port, run.shape, run.a, run.b, run.period, run.phase) == (1, "square", 0, 1, 0.1, 0)
    assert len(run.measured_t) == 20
    # the hand-made samples follow the ideal square wave exactly
    assert all(ideal_setpoint(run, t) == sp for t, sp in zip(run.measured_t, run.measured_sp))
    assert ideal_setpoint(run, 40) == 0 and ideal_setpoint(run, 50) == 1 and ideal_setpoint(run, 110) == 0


def test_ideal_shapes_follow_the_document():
    from buildhat_conformance.conformance.report.series import WaveRun

    tri = WaveRun(0, "triangle", -1, 1, 1.0, 0.0, 0)
    assert [ideal_setpoint(tri, t) for t in (0, 250, 500, 750)] == [-1, 0, 1, 0]
    pulse = WaveRun(0, "pulse", 0.5, 0, 0.2, 0.7, 0)   # phase ignored for pulse
    assert ideal_setpoint(pulse, 100) == 0.5 and ideal_setpoint(pulse, 200) == 0
    ramp = WaveRun(0, "ramp", 0, 1, 1.0, 0.5, 0)       # the phase shifts a ramp's start
    assert ideal_setpoint(ramp, 0) == 0.5 and ideal_setpoint(ramp, 1000) == 1
    sine = WaveRun(0, "sine", 0, 2, 1.0, 0.0, 0)
    assert ideal_setpoint(sine, 0) == pytest.approx(1) and ideal_setpoint(sine, 250) == pytest.approx(2)


def test_report_command_line(sample, capsys):
    out = sample / "cli.html"
    assert cli_main(["report", str(sample / "r7.xml"), "-o", str(out)]) == 0
    assert out.is_file() and "wrote" in capsys.readouterr().out
    assert cli_main(["report", str(sample / "nope.xml"), "-o", str(out)]) == 2
    bad = sample / "bad.xml"
    bad.write_text(junit_xml([{"name": "a"}], counts={"tests": "9"}), encoding="utf-8")
    assert cli_main(["report", str(bad), "-o", str(out)]) == 0
    assert cli_main(["report", str(bad), "-o", str(out), "--check"]) == 1
    broken = sample / "broken.xml"
    broken.write_text("<testsuites><testsuite", encoding="utf-8")
    capsys.readouterr()
    assert cli_main(["report", str(broken), "-o", str(out)]) == 2      # a bad file: one line, no traceback
    err = capsys.readouterr().err
    want = f"buildhat-conformance report: {broken}: not well-formed XML: unclosed token: line 1, column 12"
    assert err.splitlines() == [want], err


def test_html_escapes_what_tests_print(sample):
    run = read_junit(str(sample / "r7.xml"))
    run.cases[2].message = "<script>alert(1)</script>"
    text = report_html.render_html([run], coverage([run]), {}, [], "0")
    assert "<script>" not in text and "&lt;script&gt;" in text

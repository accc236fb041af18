"""The report's first screen from hand-made JUnit files and transcripts: the exchange that
failed (the command sent, not the end of the reply before it), failures grouped by their first
differing line, changes since the previous run of the same target, target faults, skips with
what to connect, and the timing figures and charts."""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

from buildhat_conformance.conformance.report import build_report
from buildhat_conformance.conformance.report.junit import read_junit
from buildhat_conformance.conformance.report.svg import histogram, nice_ticks
from buildhat_conformance.conformance.report.timing import collect_timing
from buildhat_conformance.conformance.report.triage import exchange_of, group_failures, headline

FENCE_ANSWER = "Firmware version: 1737564117 2025-01-22T16:41:57+00:00"
HAT_REPR = "hat = <buildhat_conformance.conformance.hat_under_test.Hat object at 0x7f45c3dcdb90>"


# The link's clean-up before a case, one write ending in its resynchronising fence.
RESYNC = "\recho 0 ; port 0 ; select\rport 3 ; pwmparams 0 0\r\recho 1\recho 0 ; version\u0000sync-170a-8\r"


def transcript(path, exchanges, t0: float = 0.0, resync: bool = False) -> str:
    """The suite's shape: a clean-up line and its fence (separate writes, or the link's one
    resynchronising write), then each command, its fence, its reply and the fence's answer (a
    CR's empty line first)."""
    events = [{"dir": "meta", "firmware": "1737564117"}]
    if resync:
        events += [{"t": t0, "dir": "host", "bytes": RESYNC}, {"t": t0 + 2, "dir": "hat", "line": ""},
                   {"t": t0 + 2, "dir": "hat", "line": "P0>echo 0 ; version\u0000sync-170a-8"}]
    else:
        events += [{"t": t0, "dir": "host", "bytes": "echo 0 ; port 0 ; select\r"},
                   {"t": t0 + 1, "dir": "host", "bytes": "version\r"},
                   {"t": t0 + 2, "dir": "hat", "line": ""}]
    events += [{"t": t0 + 2, "dir": "hat", "line": FENCE_ANSWER}]
    t = t0 + 10
    for command, reply in exchanges:
        events += [{"t": t, "dir": "host", "bytes": command + "\r"},
                   {"t": t, "dir": "host", "bytes": "version\r"}]
        events += [{"t": t + 1, "dir": "hat", "line": line} for line in [""] + reply]
        events += [{"t": t + 2, "dir": "hat", "line": ""}, {"t": t + 2, "dir": "hat", "line": FENCE_ANSWER}]
        t += 10
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(json.dumps(e) for e in events) + "\n")
    return str(path)


def junit(path, cases, target="emulator:latest") -> str:
    root = ET.Element("testsuites")
    suite = ET.SubElement(root, "testsuite", {"name": "buildhat-conformance", "tests": str(len(cases))})
    sprops = ET.SubElement(suite, "properties")
    ET.SubElement(sprops, "property", {"name": "target", "value": target})
    for c in cases:
        tc = ET.SubElement(suite, "testcase", {"classname": "conformance.test_x", "name": c["name"]})
        props = ET.SubElement(tc, "properties")
        for key, value in [("target", target)] + c.get("props", []):
            ET.SubElement(props, "property", {"name": key, "value": value})
        if "failure" in c:
            f = ET.SubElement(tc, "failure", {"message": c["failure"][0]})
            f.text = c["failure"][1]
        if "skipped" in c:
            ET.SubElement(tc, "skipped", {"message": c["skipped"]})
    ET.ElementTree(root).write(path, encoding="unicode")
    return str(path)


# pytest's own rendering of a failed ``assert got == expected`` on two multi-line strings
HELP_DETAIL = f"""{HAT_REPR}

    def test_help_text(hat):
>       assert got == expected
E       AssertionError: assert 'help\\r\\nPort <n>\\r\\nlist\\r\\n' == 'help\\r\\nport <n>\\r\\nlist\\r\\n'
E
E         - port <n>
E         + Port <n>
"""


def help_case(tmp_path, name="test_help_text[R7]"):
    path = transcript(tmp_path / f"{name}.jsonl",
                      [("?", ["help", "Port <n>", "list"]), ("list", ["P0: no device detected"])],
                      resync=True)
    return {"name": name, "failure": (HAT_REPR, HELP_DETAIL),
            "props": [("req", "CMD-HELP"), ("transcript", path), ("verdict", "fail")]}


def test_the_failing_exchange_is_the_command_sent_and_its_wrong_line(tmp_path) -> None:
    run = read_junit(junit(tmp_path / "j.xml", [help_case(tmp_path)]))
    [case] = run.cases
    assert headline(case).startswith("assert 'help") and "object at 0x" not in headline(case)
    ex = exchange_of(case)
    assert ex.sent == "?"        # the case's first command, right after the link's clean-up; not the list
    assert ex.reply == ["", "help", "Port <n>", "list"]    # the command's own CR first
    assert ex.expected == ["help", "port <n>", "list"] and ex.received == ["help", "Port <n>", "list"]
    assert (ex.first_expected, ex.first_received) == ("port <n>", "Port <n>")
    assert ex.key == "expected “port <n>” · received “Port <n>”"


def test_an_oracle_reason_marks_the_line_it_quotes(tmp_path) -> None:
    path = transcript(tmp_path / "t.jsonl", [("list", ["P0: connected to active ID 26", "type 26",
                                                       "  M0 WRONG SI =", "  nmodes =2"])])
    msg = ("buildhat_conformance.conformance.oracles.listing.ListError: line 3: "
           "expected '  M0 POWER SI = PCT', got '  M0 WRONG SI ='")
    run = read_junit(junit(tmp_path / "j.xml", [{"name": "test_list", "failure": (msg, msg), "props": [
        ("transcript", path)]}]))
    ex = exchange_of(run.cases[0])
    assert ex.why.startswith("ListError: line 3")          # no module path
    assert ex.sent == "list" and ex.reply[ex.mark] == "  M0 WRONG SI ="


def test_failures_group_by_first_differing_line_and_the_report_says_so(tmp_path) -> None:
    cases = [help_case(tmp_path, f"test_help_text[R{r}]") for r in (5, 6, 7)]
    cases.append({"name": "test_vin", "failure": ("vin printed nothing", "vin printed nothing"),
                  "props": [("req", "CMD-VIN")]})
    cases.append({"name": "test_unplug",
                  "skipped": "needs unplugging a device: target has no 'unplug' control",
                  "props": [("req", "EV-DISCONNECT")]})
    died = ("E   buildhat_conformance.harness.targets.base.TargetError: cmd:hat: the command exited with "
            "status 2; its last stderr lines:\n      usage: hat [-h]\n      hat: error: bad option")
    cases.append({"name": "test_after_reboot", "failure": ("target fault (unreachable): it exited", died),
                  "props": [("verdict", "target-fault")]})
    cases.append({"name": "test_bias_removed", "failure": (HAT_REPR, f"{HAT_REPR}\nbias answered Error"),
                  "props": [("verdict", "known deviation"), ("deviations", "BIAS-REMOVED")]})
    for name in ("test_next", "test_after_next"):
        cases.append({"name": name, "failure": ("buildhat_conformance.conformance.plugin.run.NotRun: "
                                                "not run: cannot open target cmd:hat", ""),
                      "props": [("verdict", "not-run")]})
    run = read_junit(junit(tmp_path / "j.xml", cases))
    fails = [(run, c) for c in run.cases if c.verdict == "fail"]
    groups = group_failures(fails)
    assert [len(g.members) for g in groups] == [3, 1]
    assert groups[0].key == "expected “port <n>” · received “Port <n>”"

    out = build_report([str(tmp_path / "j.xml")], str(tmp_path / "index.html"))
    text = open(out, encoding="utf-8").read()
    head = text[:text.index("id=by-requirement")]
    assert "FAILS: 4 finding(s)" in head
    for count, word in ((4, "fail"), (1, "target fault"), (2, "not run"), (1, "skip"), (0, "pass")):
        assert f"<b>{count}</b> {word}</a>" in head, word
    failures = head[head.index("id=failures"):head.index("id=faults")]
    assert "3 kind(s)" not in failures and "2 kind(s)" in failures
    assert "&gt; ?</code>" in failures
    assert "<tr class=first><td>port &lt;n&gt;</td><td>Port &lt;n&gt;</td></tr>" in failures
    faults = head[head.index("id=faults"):head.index("id=skips")]
    assert "test_after_reboot" in faults and "it exited" in faults
    assert "<pre>usage: hat [-h]\nhat: error: bad option</pre>" in faults        # why it died, in sight
    assert "<b>2</b> case(s): <span class=tests>test_after_next, test_next</span></td>" \
           "<td>cannot open target cmd:hat</td>" in faults                     # not-run: one row per reason
    skips = head[head.index("id=skips"):]
    assert "needs unplugging a device: target has no &#x27;unplug&#x27; control" in skips
    legend = text[text.index("id=legend"):]
    for sign in ("<code>obs</code>", "<code>K</code>", "<code>I</code>", "<code>T</code>", "<code>N</code>"):
        assert sign in legend
    assert "a section of docs/FIRMWARE-BEHAVIOUR.md" in legend
    assert "object at 0x" not in text
    # the known deviation cites the project's behaviour document and quotes what it says there
    dev = text[text.index("id=deviations"):text.index("id=plots")]
    assert "<code>docs/FIRMWARE-BEHAVIOUR.md#fb-command-table, #fb-doc-bias</code>" in dev
    quoted = dev[dev.index("<summary>what it says</summary><pre>"):]
    assert "On R6+ `bias` is `Error` (`pwmparams` replaced it)" in quoted and "&lt;a id=" not in quoted
    assert "FIRMWARE-FACTS" not in text


def test_changes_since_the_previous_run_of_the_same_target(tmp_path) -> None:
    runs = tmp_path / "reports" / "runs"
    old, other, new = (runs / "20260101T000000Z-emulator", runs / "20260102T000000Z-serial",
                       runs / "20260103T000000Z-emulator")
    for d in (old, other, new):
        d.mkdir(parents=True)
    junit(old / "junit.xml", [{"name": "test_a"}, {"name": "test_b", "failure": ("b broke", "b broke")},
                              {"name": "test_c"}])
    junit(other / "junit.xml", [{"name": "test_a", "failure": ("x", "x")}], target="/dev/ttyAMA0")
    junit(new / "junit.xml", [{"name": "test_a", "failure": ("a broke", "a broke")}, {"name": "test_b"},
                              {"name": "test_c"}])
    text = open(build_report([str(new / "junit.xml")], str(new / "index.html")), encoding="utf-8").read()
    line = re.search(r"<p class=changes>(.*?)</p>", text).group(1)
    assert "20260101T000000Z-emulator" in line         # the same target's run, not the serial one
    assert "1 newly failing</b>: test_a (pass → fail)" in line and "1 fixed</b>: test_b (fail → pass)" in line
    assert "test_c" not in line
    first = open(build_report([str(old / "junit.xml")], str(old / "index.html")), encoding="utf-8").read()
    assert "No earlier run of this target" in first


def test_timing_figures_from_data_lines_and_done_lines(tmp_path) -> None:
    events = [{"dir": "meta"}, {"t": 0, "dir": "host", "bytes": "port 0 ; set pulse 1 0 0.1 0\r"}]
    events += [{"t": 5 + 100 * k, "dir": "hat", "line": f"P1M0: {k}"} for k in range(6)]
    events += [{"t": 50, "dir": "hat", "line": "P2C0: 1 2"}, {"t": 3000, "dir": "hat", "line": "P2C0: 1 2"}]
    events += [{"t": 104, "dir": "hat", "line": "P0: pulse done"}]
    path = tmp_path / "t.jsonl"
    path.write_text("\n".join(json.dumps(e) for e in events) + "\n", encoding="utf-8")
    timing = collect_timing([(str(path), "test_x"), (str(tmp_path / "missing.jsonl"), "gone")])
    assert timing.periods == [100.0] * 5        # P2's 2950 ms gap is a stop, not a period
    assert timing.lateness == [4.0] and "P0 pulse 0.1 s (test_x)" in timing.lateness_labels


def test_charts_are_svg_with_round_ticks() -> None:
    assert nice_ticks(0, 1) == [0, 0.2, 0.4, 0.6, 0.8, 1.0]
    assert nice_ticks(3, 97, 4) == [20, 40, 60, 80]
    svg = histogram([100.0] * 9 + [110.0], "periods <ms>", "ms")
    assert svg.startswith("<svg class=chart") and "periods &lt;ms&gt;" in svg
    assert re.findall(r"<title>(\d+)</title>", svg) == ["9", "1"]      # one bar per filled bin


def test_every_known_deviation_is_explained_for_the_report() -> None:
    from buildhat_conformance.conformance.deviations import deviations

    for key, d in deviations().items():
        assert d.explain and d.explain.endswith(".") and len(d.explain) < 400, key
        # explained by anchors of docs/FIRMWARE-BEHAVIOUR.md (tests/protocol/test_behaviour.py: they exist)
        assert d.behaviour and all(re.fullmatch(r"fb-[a-z0-9-]+", a) for a in d.behaviour), key
        assert d.reference.startswith("docs/FIRMWARE-BEHAVIOUR.md#" + d.behaviour[0]), key

"""A firmware in the loop that crashes or breaks a sanitizer's rule, through the user's commands
(issue 34, items 1 and 3): the case that met it fails naming it, the firmware is started again and
every other case keeps its usual verdict; each report is listed once (terminal, JUnit, the HTML
report's first screen); a suppressions file turns them into listed-but-suppressed; `fuzz` keeps
each as a finding that `fuzz --reproduce` reproduces, exit 1.

The planted bug is the test's own: a store through a null pointer of type `float` in the code of
`ledmode`, reached only by the value 7, which one case alone sends
(`test_ledmode_accepts_its_values_silently[7]`)."""
import json
import os
import re
import xml.etree.ElementTree as ET

import pytest
from junit_props import suite_properties
from sil_support import cli, copy_tree, firmware_tree, junit_verdicts, plant, whole_suite

pytestmark = [pytest.mark.timeout(1200), pytest.mark.slow]

PLANTED_CASE = "test_ledmode_accepts_its_values_silently[7]"
SANITIZE = "sanitize=address,undefined"


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("silcache")


@pytest.fixture(scope="module")
def plain_r7(cache, tmp_path_factory):
    """Every case's verdict on the unchanged R7 tree, plain build: what every other case must keep."""
    done, verdicts = whole_suite(cache, tmp_path_factory.mktemp("r7"))
    assert done.returncode == 0, done.stdout[-3000:]
    return {name: verdict for name, verdict, _m in verdicts}


@pytest.fixture(scope="module")
def planted_tree(tmp_path_factory):
    tree = copy_tree(tmp_path_factory.mktemp("planted") / "tree")
    plant(tree, "command.c", "  CLAMP(u,-1,3);\n  ledmode=u;",
          "  { static float *volatile planted; if (u == 7) *(volatile float *)planted = 1.0f; }\n"
          "  CLAMP(u,-1,3);\n  ledmode=u;")
    return tree


def _defects(junit) -> list:
    return json.loads(suite_properties(ET.parse(junit).getroot()).get("firmware_defects", "[]"))


@pytest.mark.parametrize("options, named", [("", "the firmware crashed (SIGSEGV)"),
                                            (f"?{SANITIZE}", "runtime error: store to null pointer")],
                         ids=["plain", "sanitized"])
def test_a_planted_null_store_fails_its_case_and_the_run_goes_on(cache, tmp_path, plain_r7, planted_tree,
                                                                 options, named):
    junit = tmp_path / "junit.xml"
    done = cli("run", "--target", f"sil:{planted_tree}{options}", "--junit", str(junit), cache=cache,
               timeout=900)
    assert done.returncode == 1, done.stdout[-3000:] + done.stderr[-2000:]
    verdicts = {name: (verdict, message) for name, verdict, message in junit_verdicts(junit)}
    verdict, message = verdicts.pop(PLANTED_CASE)
    assert verdict == "fail" and named in message, (verdict, message)
    # Listed once, with its case (the sanitized build also lists R7's own reports, each failing the
    # case that met it: test_r7_sanitized_gives_the_plain_verdicts_and_lists_its_own_reports_once).
    defects = _defects(junit)
    planted = [d for d in defects if f"test_commands.py::{PLANTED_CASE}" in d["cases"]]
    assert planted and all(d["cases"] == [f"test_commands.py::{PLANTED_CASE}"] for d in planted), defects
    assert all(d["file"] != "command.c" for d in defects if d not in planted), defects
    if not options:
        assert len(defects) == 1, defects       # the plain build: the crash alone
    r7_own = {case.split("::", 1)[1] for d in defects if d not in planted for case in d["cases"]}
    changed = {n: v for n, v in verdicts.items() if v[0] != plain_r7.get(n) and n not in r7_own}
    assert not changed, changed
    assert set(verdicts) | {PLANTED_CASE} == set(plain_r7)
    assert f"firmware defects found by the sanitizers: {len(defects)}" in done.stdout
    transcript = next((tmp_path / "transcripts").glob("*ledmode_accepts_its_values_silently_7*.jsonl"))
    text = transcript.read_text()
    assert ("sil: the firmware was killed by SIGSEGV" if not options else "AddressSanitizer: SEGV") in text
    assert "Firmware version: 1737564117" in text.rsplit("SEGV", 1)[1], "the firmware was not started again"
    assert "Firmware defects found by the sanitizers" in (tmp_path / "index.html").read_text()


def test_r7_sanitized_gives_the_plain_verdicts_and_lists_its_own_reports_once(cache, tmp_path, plain_r7):
    junit = tmp_path / "run1" / "junit.xml"
    done = cli("run", "--target", f"sil:{firmware_tree()}?{SANITIZE}", "--junit", str(junit), cache=cache,
               timeout=900)
    defects = _defects(junit)
    assert defects, done.stdout[-3000:]
    keys = [(d["kind"], d["file"], d["line"]) for d in defects]
    assert len(keys) == len(set(keys))
    met = {case.split("::", 1)[1] for d in defects for case in d["cases"]}
    for name, verdict, message in junit_verdicts(junit):
        if name in met:       # a case that met a report fails with its first line
            assert verdict == "fail" and re.search(r"(UndefinedBehavior|Address)Sanitizer", message), message
        else:
            assert verdict == plain_r7[name], (name, verdict, message)
    assert done.returncode == 1
    for d in defects:
        assert f"{d['kind']} at {d['file']}:{d['line']}" in done.stdout
    # Acknowledged in a suppressions file (the sanitizers' kind:pattern), nothing fails.
    rules = tmp_path / "r7.supp"
    rules.write_text("".join(f"{d['kind']}:{d['file']}\n" for d in defects))
    junit2 = tmp_path / "run2" / "junit.xml"
    done = cli("run", "--target", f"sil:{firmware_tree()}?{SANITIZE}&suppressions={rules}", "--junit",
               str(junit2), cache=cache, timeout=900)
    assert done.returncode == 0, done.stdout[-3000:]
    assert {n: v for n, v, _m in junit_verdicts(junit2)} == plain_r7
    again = _defects(junit2)
    assert again and all(d["suppressed_by"] for d in again)
    assert re.search(r"firmware defects found by the sanitizers: 0 \(and \d+ suppressed\)", done.stdout)


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_fuzzing_the_sanitized_r7_keeps_its_findings(cache, tmp_path, jobs):
    out = tmp_path / "fuzz"
    target = f"sil:{firmware_tree()}?{SANITIZE}"
    done = cli("fuzz", "-t", target, "--budget", "30s", "--seed", "2228852397", "--jobs", jobs,
               "-o", str(out), cache=cache, timeout=600)
    assert done.returncode == 1, done.stdout[-3000:] + done.stderr[-2000:]
    scripts = sorted(out.glob("*.script"))
    assert scripts, done.stdout[-3000:]
    junit = ET.parse(out / "junit.xml").getroot()
    failed = {case.get("name") for case in junit.iter("testcase") if case.find("failure") is not None}
    assert {p.stem for p in scripts} <= failed
    assert failed & {"crash", "sanitizer"}, failed
    for script in scripts:
        again = cli("fuzz", "--reproduce", str(script), "--confirm", "1", cache=cache, timeout=300)
        assert again.returncode == 1 and "reproduced" in again.stdout, again.stdout + again.stderr


@pytest.mark.parametrize("options", ["", f"?{SANITIZE}"], ids=["plain", "sanitized"])
def test_a_crash_replayed_by_the_fuzzer_is_a_crash_finding(cache, tmp_path, planted_tree, options):
    script = tmp_path / "crash.script"
    # (as the fuzzer writes a step: its lines, then the fence `version`; the first step is the prelude)
    script.write_text(f";; target: sil:{planted_tree}{options}\n@name fuzz finding (crash): planted\n"
                      "> echo 0\n> version\n> ledmode 7\n> version\n")
    done = cli("fuzz", "--reproduce", str(script), "--confirm", "2", cache=cache, timeout=300)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "reproduced (2/2" in done.stdout and "[crash]" in done.stdout, done.stdout
    assert os.path.basename(str(planted_tree)) in done.stdout

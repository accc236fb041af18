"""The real firmware in the loop as a target (``sil:TREE``), through the user's own commands:
the suite agrees with it in virtual time, a planted regression fails, a planted memory error fails
the case that meets it naming its sanitizer, runs repeat byte for byte, coverage is reported."""
import json

import pytest
from sil_support import cli, copy_tree, firmware_tree, junit_verdicts, plant  # noqa: E402
from sil_support import whole_suite as run_whole_suite

pytestmark = pytest.mark.timeout(900)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("silcache")


@pytest.fixture(scope="module")
def whole_suite(cache, tmp_path_factory):
    return run_whole_suite(cache, tmp_path_factory.mktemp("silrun"))


def test_the_suite_passes_on_the_real_firmware_with_nothing_skipped(whole_suite):
    done, verdicts = whole_suite
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert len(verdicts) > 300
    kinds = {v for _name, v, _msg in verdicts}
    assert not kinds & {"fail", "target-fault", "not-run", "skip"}, \
        [(n, v, m) for n, v, m in verdicts if v in ("fail", "target-fault", "not-run", "skip")]


def test_abbreviation_cases_after_the_link_clauses_are_neither_faults_nor_failures(cache, tmp_path):
    # Deterministic (virtual time): this sequence once lost the stand-in's UART TX interrupt
    # (a `list` stopped after "P0: con" until the next host line: a false "garbled" target fault)
    # and then put a PID line between the fence's echo and its CRLF (the `port` probe's reply
    # kept "version": a false failure). tests/sil/test_hat.py and
    # tests/conformance/test_reply.py hold each of them on its own.
    junit = tmp_path / "junit.xml"
    done = cli("run", "--target", f"sil:{firmware_tree()}", "-k",
               "test_clause_semicolon or shortest_resolving_prefix_runs_the_command", "--junit", str(junit),
               cache=cache)
    verdicts = junit_verdicts(junit)
    bad = [(n, v, m) for n, v, m in verdicts if v in ("fail", "target-fault", "not-run", "skip")]
    assert done.returncode == 0 and not bad and len(verdicts) > 20, (bad, done.stdout[-2000:])


def test_a_planted_change_in_a_reply_fails_the_suite(cache, tmp_path):
    tree = copy_tree(tmp_path / "planted")
    plant(tree, "command.c", 'ostrnl(" V")', 'ostrnl(" v")')      # `vin` prints "8.00 v"
    junit = tmp_path / "junit.xml"
    done = cli("run", "--target", f"sil:{tree}", "-k", "vin", "--junit", str(junit), cache=cache)
    assert done.returncode == 1, done.stdout[-2000:] + done.stderr[-2000:]
    failed = [n for n, v, _m in junit_verdicts(junit) if v == "fail"]
    assert any("vin" in n for n in failed), failed


def test_a_planted_out_of_bounds_write_fails_the_case_that_meets_it_naming_its_sanitizer(cache, tmp_path):
    # A firmware in the loop's sanitizer report is its own defect, not a target fault (issue 34; the
    # whole story in tests/end_to_end/test_sil_crashes.py): the firmware goes on after it.
    tree = copy_tree(tmp_path / "oob")
    plant(tree, "command.c", "static int cmd_vin()         {",
          "static int cmd_vin()         { { static char planted[4]; volatile int k = 4; planted[k] = 1; }")
    junit = tmp_path / "junit.xml"
    url = f"sil:{tree}?sanitize=address,undefined"
    done = cli("run", "--target", url, "-k", "vin", "--junit", str(junit), cache=cache)
    assert done.returncode == 1, done.stdout[-2000:] + done.stderr[-2000:]
    verdicts = junit_verdicts(junit)
    failed = [m for _n, v, m in verdicts if v == "fail"]
    assert failed and not [v for _n, v, _m in verdicts if v in ("target-fault", "not-run")], verdicts
    assert failed[0].startswith("UndefinedBehaviorSanitizer: command.c:") and "out of bounds" in failed[0]
    transcripts = tmp_path / "transcripts"
    reports = [p for p in transcripts.glob("*.jsonl") if "runtime error" in p.read_text()]
    assert reports, "the sanitizer's report is not in the transcript"


def test_two_runs_give_the_same_bytes_at_the_same_times(cache, tmp_path):
    script = tmp_path / "s.script"
    script.write_text("@device 0 0x30\n@device 1 0x40\n@device 2 passive 8\n@device 3 none\n"
                      "> list\n> port 0 ; select 0 ; pwm ; set 0.5\n@wait 400\n> port 0 ; coast ; vin\n"
                      "@wait 50\n@plug 3 0x3D\n@wait 4000\n> list\n")
    runs = []
    for n in range(2):
        out = tmp_path / f"t{n}.jsonl"
        done = cli("script", str(script), "--target", f"sil:{firmware_tree()}", "-o", str(out), cache=cache)
        assert done.returncode == 0, done.stderr
        rows = [json.loads(line) for line in out.read_text().splitlines()]
        # A half line may be written early (when it waits on the wall clock): the bytes are
        # compared, not where the writer cut them.
        hat = "".join(r["partial"] if "partial" in r else r["line"] + "\n"
                      for r in rows if r.get("dir") == "hat")
        host = [(r["t"], r["bytes"]) for r in rows if r.get("dir") == "host"]
        runs.append((hat, host))
    assert runs[0] == runs[1]
    assert "P3: established serial communication with active ID 3D" in runs[0][0]


def test_a_coverage_build_reports_the_firmwares_coverage(cache, tmp_path):
    junit = tmp_path / "junit.xml"
    done = cli("run", "--target", f"sil:{firmware_tree()}?coverage=1", "-k", "version", "--junit", str(junit),
               cache=cache)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    summary = json.loads((tmp_path / "firmware-coverage.json").read_text())
    names = {f["name"] for f in summary["files"]}
    assert {"main.c", "command.c", "ports.c"} <= names
    assert 10 < summary["line_percent"] < 100
    assert "firmware coverage: lines" in done.stdout


def test_a_long_list_stretches_the_main_loop_as_on_a_hat(cache, tmp_path):
    """docs/FIRMWARE-BEHAVIOUR.md#fb-stall: a real HAT prints deltat=00000003 right after the
    `list` of a motor, a distance sensor and a colour sensor. The stand-in's CPU model (the cost
    of a basic block and of software float) is calibrated on that fact."""
    script = tmp_path / "list.script"
    script.write_text("@device 0 0x30\n@device 1 0x3E\n@device 2 0x3D\n@device 3 none\n> list\n@wait 400\n")
    out = tmp_path / "list.jsonl"
    done = cli("script", str(script), "--target", f"sil:{firmware_tree()}", "-o", str(out), cache=cache)
    assert done.returncode == 0, done.stderr
    lines = [json.loads(r).get("line") for r in out.read_text().splitlines()]
    after_list = lines[max(i for i, ln in enumerate(lines) if ln and ln.startswith("P3: ")):]
    assert "deltat=00000003" in after_list, after_list[:8]

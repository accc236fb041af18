"""`sil mutate` end to end through the user's command: a small seeded campaign on the real
firmware's tree, with a planted regression the suite must kill by a failing case."""
import json

import pytest
from sil_support import cli, firmware_tree  # noqa: E402

pytestmark = pytest.mark.timeout(900)


def test_a_small_campaign_kills_the_planted_regression(tmp_path):
    out = tmp_path / "mut"
    done = cli("sil", "mutate", str(firmware_tree()), "--count", "3", "--seed", "5", "-k", "test_commands",
               "--plant", 'command.c:ostrnl(" V"):ostrnl(" v")', "-o", str(out), cache=tmp_path / "cache")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    summary = json.loads((out / "mutation.json").read_text())
    assert len(summary["mutants"]) == 4 and sum(summary["counts"].values()) == 4
    mine = next(m for m in summary["mutants"] if m["kind"] == "planted")
    assert mine["status"] == "killed" and any("vin" in c for c in mine["cases"]), mine
    assert "mutation score" in done.stdout and (out / "mutation.html").exists()


def test_hat_output_compares_lines_however_the_reads_cut_them(tmp_path):
    from buildhat_conformance.conformance.case_output import case_lines

    def transcript(name, events):
        path = tmp_path / name
        path.write_text("".join(json.dumps(e) + "\n" for e in events))
        return str(path)

    def run(*cases):
        return case_lines([(f"case{i}", "pass", [], transcript(f"{id(cases)}-{i}.jsonl", events))
                            for i, events in enumerate(cases)])

    whole = run([{"t": 1, "dir": "hat", "line": "    RAW: 00 SI: 01"},
                 {"t": 2, "dir": "hat", "line": "echo 0 ; version sync-6c7b-142"},
                 {"t": 3, "dir": "hat", "line": "P3M3: +49"}],
                [{"t": 1, "dir": "hat", "line": ""}])
    cut = run([{"t": 1, "dir": "hat", "partial": "    RAW: 00 "},
               {"t": 1, "dir": "host", "bytes": "list\r"},
               {"t": 9, "dir": "hat", "line": "SI: 01"},
               {"t": 9, "dir": "hat", "line": "echo 0 ; version sync-7320-142"},
               {"t": 9, "dir": "hat", "partial": "P3M3: +"}],
              [{"t": 1, "dir": "hat", "line": "49"}, {"t": 1, "dir": "hat", "line": ""}])
    other = run([{"t": 1, "dir": "hat", "line": "    RAW: 00 SI: 02"},
                 {"t": 2, "dir": "hat", "line": "echo 0 ; version sync-6c7b-142"},
                 {"t": 3, "dir": "hat", "line": "P3M3: +49"}],
                [{"t": 1, "dir": "hat", "line": ""}])
    assert whole == cut
    assert whole["case0"] == ["    RAW: 00 SI: 01", "echo 0 ; version sync-*", "P3M3: +49"]
    assert whole["case0"] != other["case0"] and whole["case1"] == other["case1"]


def test_killers_of_an_earlier_campaign_run_first_in_their_rank(tmp_path):
    from types import SimpleNamespace

    from buildhat_conformance.campaigns.first_failure_plugin import killers, pytest_collection_modifyitems

    summary = tmp_path / "mutation.json"
    summary.write_text(json.dumps({"mutants": [
        {"status": "killed", "cases": ["test_b::one", "test_a::late"]},
        {"status": "killed", "cases": ["test_c::two[x]"]},
        {"status": "killed", "cases": ["test_c::two[x]"]},
        {"status": "survived", "cases": ["test_a::first"]},
        {"status": "killed-by-fault", "cases": ["test_a::first"]}]}))
    ranked = killers(summary)
    assert ranked == ["test_c::two[x]", "test_b::one"]      # the first failing case of each killed mutant
    order = tmp_path / "order.txt"
    order.write_text("".join(c + "\n" for c in ranked))
    items = [SimpleNamespace(fspath=f"/s/{m}.py", name=n)
             for m, n in [("test_a", "first"), ("test_b", "one"), ("test_a", "late"), ("test_c", "two[x]")]]
    pytest_collection_modifyitems(SimpleNamespace(getoption=lambda name: str(order)), items)
    assert [f"{i.fspath[3:-3]}::{i.name}" for i in items] == \
        ["test_c::two[x]", "test_b::one", "test_a::first", "test_a::late"]   # the rest as collected


def test_a_build_hat_breaking_a_clause_at_open_is_killed_not_refused(tmp_path):
    """Issue 25: mutants the run used to refuse as "not like a Build HAT" (no boot). One answers
    `version` with `Error`, one floods `Port power fault`; each shows a Build HAT (the CRLF and
    `Error`; its start-up after a reset) and fails the clause it breaks. A silent one stays no-boot."""
    out = tmp_path / "mut"
    done = cli("sil", "mutate", str(firmware_tree()), "--count", "0", "--jobs", "1",
               "--killers-first", "none",
               "-k", "test_clause or power_fault",
               "--plant", "control.c:cmdbuf[cbrptr]==' '||cmdbuf:cmdbuf[cbrptr]!=' '||cmdbuf",
               "--plant", "main.c:gtimers[0]>10&&:gtimers[0]>10||",
               "--plant", "control.c:if(u==0x0d):if(u==0x0e)",
               "-o", str(out), cache=tmp_path / "cache")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    summary = json.loads((out / "mutation.json").read_text())
    mutants = {m["file"] + ":" + str(m["line"]): m for m in summary["mutants"]}
    version, flood = mutants["control.c:123"], mutants["main.c:136"]
    assert version["status"] == "killed" and version["cases"] == [
        "test_link_clauses::test_clause_version_answers_one_line"], version
    assert flood["status"] == "killed" and "power_fault" in flood["cases"][0], flood
    silent = [m for k, m in mutants.items() if k not in ("control.c:123", "main.c:136")]
    assert [m["status"] for m in silent] == ["no-boot"], silent


def test_a_plant_that_makes_the_same_file_as_another_mutant_is_refused(tmp_path):
    """Two mutants that make the same file share a build folder, which the first to finish removes
    under the other: one line, exit 2, before anything is built."""
    plant = 'command.c:ostrnl(" V"):ostrnl(" v")'
    for second in (plant, 'command.c:" V":" v"'):
        done = cli("sil", "mutate", str(firmware_tree()), "--count", "0", "--plant", plant, "--plant", second,
                   "-o", str(tmp_path / "mut"), cache=tmp_path / "cache")
        assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
        assert len(done.stderr.strip().splitlines()) == 1 and "makes the same command.c as" in done.stderr
    assert not (tmp_path / "mut").exists() and not (tmp_path / "cache").exists()

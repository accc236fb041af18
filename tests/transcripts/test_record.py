"""`record` and `replay` on the in-process emulator (virtual time, so exact and quick), and what
they say when a target cannot do what a recording needs."""
from __future__ import annotations

from repo_paths import REPO

from buildhat_conformance.cli import main as cli_main
from buildhat_conformance.harness.transcript import read_transcript

SCRIPT = """@name plug and data
@device 3 0x3D
> port 3 ; select 0
@wait 250
@unplug 1
@wait 700
> list
"""


def test_record_on_inprocess_then_replay_matches(tmp_path, capsys):
    script = tmp_path / "plug.script"
    script.write_text(SCRIPT, encoding="utf-8")
    out = tmp_path / "plug.jsonl"
    assert cli_main(["record", str(script), "--target", "inprocess:1737564117", "-o", str(out)]) == 0
    t = read_transcript(str(out))
    assert t.meta["script"] == "plug.script" and t.meta["devices"]["3"] == "0x3D"
    assert t.meta["firmware"] == "1737564117 2025-01-22T16:41:57+00:00" and t.meta["date"]
    lines = t.hat_lines()
    # the world action happened: the data-phase watchdog (> 500 ms, FACTS §5) then `disconnected`
    assert "P3M0: -1" in lines and "P1: disconnected" in lines
    assert "P1: timeout during data phase: disconnecting" in lines
    assert "P1: no device detected" in lines and "P3: connected to active ID 3D" in lines
    capsys.readouterr()
    # the layout and the @unplug come from the script named in meta
    assert cli_main(["replay", str(out), "--target", "inprocess:1737564117"]) == 0
    assert "MATCH" in capsys.readouterr().out


def test_world_actions_come_from_the_notes_and_their_absence_shows(tmp_path, capsys):
    import json

    script = tmp_path / "plug.script"
    script.write_text(SCRIPT, encoding="utf-8")
    out = tmp_path / "plug.jsonl"
    assert cli_main(["record", str(script), "--target", "inprocess", "-o", str(out)]) == 0
    capsys.readouterr()
    # without its script, the recording's own "world @unplug 1 -> ok" note still drives the world
    script.unlink()
    assert cli_main(["replay", str(out), "--target", "inprocess", "--rule", "data=ignore"]) == 0
    text = capsys.readouterr().out
    assert "world actions come from the notes" in text and "MATCH" in text
    # a copy that has lost both (as a hardware recording would): the motor on P1 stays plugged in
    bare = tmp_path / "bare.jsonl"
    with open(out, encoding="utf-8") as src, open(bare, "w", encoding="utf-8") as dst:
        for line in src:
            obj = json.loads(line)
            if obj["dir"] == "note":
                continue
            obj.pop("script", None)
            dst.write(json.dumps(obj) + "\n")
    assert cli_main(["replay", str(bare), "--target", "inprocess", "--rule", "data=ignore"]) == 1
    text = capsys.readouterr().out
    assert "- P1: timeout during data phase: disconnecting" in text and "- P1: disconnected" in text
    assert "- P1: no device detected" in text and "+ P1: connected to active ID 40" in text


def test_record_refuses_a_script_the_target_cannot_run(tmp_path, capsys):
    script = tmp_path / "plug.script"
    script.write_text(SCRIPT, encoding="utf-8")
    rc = cli_main(["record", str(script), "--target", "loop://", "-o", str(tmp_path / "x.jsonl")])
    err = capsys.readouterr().err
    assert rc == 3 and "@unplug" in err and "Nothing was sent" in err
    assert not (tmp_path / "x.jsonl").exists()


def test_replay_refuses_a_mismatched_script(tmp_path, capsys):
    script = tmp_path / "plug.script"
    script.write_text(SCRIPT, encoding="utf-8")
    out = tmp_path / "plug.jsonl"
    assert cli_main(["record", str(script), "--target", "inprocess", "-o", str(out)]) == 0
    other = tmp_path / "other.script"
    other.write_text("> vin\n", encoding="utf-8")
    assert cli_main(["replay", str(out), "--target", "inprocess", "--script", str(other)]) == 2
    assert "does not send what the transcript's host events hold" in capsys.readouterr().err


def test_script_record_and_replay_are_one_runner(tmp_path, capsys):
    """`script`, `record` and `replay` run a scenario the same way (one runner,
    transcripts/script_runner.py): on the in-process emulator their transcripts after t = 0 are the
    same bytes at the same times, and the lines the emulator's own script mode wrote in the
    golden transcript (reviewed against FIRMWARE-FACTS in tests/end_to_end/test_transcripts_golden.py)."""

    golden = REPO / "transcripts" / "data"
    script = str(golden / "appendix-a-motor.script")
    target = "inprocess:1737564117"
    ran, recorded, replayed = (str(tmp_path / n) for n in ("script.jsonl", "record.jsonl", "replay.jsonl"))
    assert cli_main(["script", script, "-t", target, "-o", ran, "-q"]) == 0
    assert cli_main(["record", script, "-t", target, "-o", recorded]) == 0
    assert cli_main(["replay", recorded, "-t", target, "-o", replayed]) == 0
    capsys.readouterr()

    def after_zero(path: str) -> list:
        """From the first host line at t >= 0 on (the in-process start-up is read at t = 0)."""
        events = [(e["t"], e["dir"], e.get("bytes", e.get("line", e.get("partial"))))
                  for e in read_transcript(path).events if e["dir"] in ("host", "hat") and e["t"] >= 0]
        return events[next(i for i, e in enumerate(events) if e[1] == "host"):]

    got = after_zero(ran)
    assert after_zero(recorded) == got and after_zero(replayed) == got
    # the same lines as script mode, within the in-process target's 1-2 ms phase (as in the golden test)
    expected = after_zero(str(golden / "appendix-a-motor.jsonl"))
    assert len(expected) > 20 and [e[1:] for e in got] == [e[1:] for e in expected]
    assert all(abs(g[0] - e[0]) <= 2 for g, e in zip(got, expected))

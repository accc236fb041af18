"""The benchmark table: medians, goals met or not, failures shown rather than raised."""
import argparse
import json

from buildhat_conformance.bench import cli
from buildhat_conformance.bench.figures import Figure, render_table


def test_median_and_goal():
    f = Figure("lines/s", "lines/s", ">= 5,000", "higher", 5000.0, samples=[4000.0, 6000.0, 7000.0])
    assert f.value == 6000.0 and f.met is True
    g = Figure("wall", "s", "<= 20 s", target=20.0, samples=[25.0])
    assert g.met is False
    assert Figure("x", "s").met is None


def test_table_marks_unmet_goals_and_notes():
    table = render_table([Figure("wall", "s", "<= 20 s", target=20.0, samples=[25.0]),
                          Figure("broken", "s", note="RuntimeError: boom")])
    lines = table.splitlines()
    assert "NO" in lines[2] and "RuntimeError: boom" in lines[3]


def test_a_failing_group_blanks_its_figures(monkeypatch, tmp_path):
    def boom():
        raise RuntimeError("no emulator here")

    groups = [("broken", boom, [(Figure("a", "s"), "k")]),
              ("fine", lambda: {"k": 2.0}, [(Figure("b", "s", target=3.0), "k")])]
    monkeypatch.setattr(cli, "_groups", lambda quick: groups)
    out = tmp_path / "bench.json"
    assert cli.main(argparse.Namespace(runs=2, quick=False, only="", output=str(out))) == 0
    data = json.loads(out.read_text())
    a, b = data["figures"]
    assert a["value"] is None and "no emulator here" in a["note"]
    assert b["samples"] == [2.0, 2.0] and b["met"] is True

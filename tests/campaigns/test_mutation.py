"""campaigns/mutation.py's campaign figures and campaigns/mutation_report.py's page, from outcomes made here
(the campaign's runs themselves: tests/end_to_end/test_sil_mutate.py)."""
import json

from buildhat_conformance.campaigns.mutants import Mutant
from buildhat_conformance.campaigns.mutation import Campaign, Outcome
from buildhat_conformance.campaigns.mutation_report import write_reports


def _campaign(*statuses):
    outcomes = [Outcome(Mutant("main.c", 10 + i, 100 + i, "planted", "a", "b"), status)
                for i, status in enumerate(statuses)]
    return Campaign("/tree", outcomes, seconds=1.0, reference_cases=3)


def test_no_score_when_no_mutant_is_left_to_judge(tmp_path):
    """Every mutant likely equivalent (or not built, not booted): there is no score, and no
    "nan%" on the line, the page or in the JSON (which NaN would make invalid)."""
    campaign = _campaign("likely-equivalent", "no-build")
    assert campaign.judged == 0 and campaign.score is None
    line = campaign.summary_line()
    assert line.startswith("mutation score none (0 killed by a failing case of 0 not likely equivalent)")
    assert "nan" not in line.lower()
    page = write_reports(campaign, tmp_path).read_text()
    assert "Mutation score none" in page and "nan" not in page.lower()
    summary = json.loads((tmp_path / "mutation.json").read_text(), parse_constant=lambda c: 1 / 0)
    assert summary["score"] is None and summary["judged"] == 0


def test_the_score_counts_killed_of_judged():
    campaign = _campaign("killed", "killed", "survived", "killed-by-fault", "likely-equivalent", "no-boot")
    assert campaign.judged == 4 and campaign.score == 50.0
    assert campaign.summary_line().startswith("mutation score 50.0% (2 killed by a failing case of 4 ")
    assert campaign.as_dict()["score"] == 50.0


def test_a_phase_control_runs_the_suite_on_a_chip_started_later(tmp_path, monkeypatch):
    from buildhat_conformance.campaigns import mutation
    seen = []

    class Done:
        returncode, stdout, stderr = 0, "", ""

    def fake_run(argv, **kw):
        seen.append((kw.get("env") or {}).get("BUILDHAT_SIL_START_NS"))
        return Done()
    monkeypatch.setattr(mutation.subprocess, "run", fake_run)
    mutation._control("/prog", tmp_path / "c0", None, None)
    mutation._control("/prog", tmp_path / "c1", None, None, mutation.PHASE_CONTROLS_NS[0])
    assert seen == [None, str(mutation.PHASE_CONTROLS_NS[0])]

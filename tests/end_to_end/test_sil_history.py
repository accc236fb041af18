"""`sil history` and `sil history-merge` through the user's command, on a git history the test
makes from the R7 tree: four commits, the second does not build, the third changes the help text.
Two parts merged give what one run over every commit gives."""
import json

import pytest
from sil_support import cli, git_history

pytestmark = pytest.mark.timeout(900)


def _history(repo):
    """Four commits in firmware-pico/: the second does not build, the third changes the help text."""
    return git_history(repo, "firmware-pico", 4, 3, broken=2)


@pytest.mark.slow
def test_two_parts_of_a_history_merged_are_the_whole(tmp_path):
    repo = tmp_path / "fw"
    shas = _history(repo)
    common = [shas[0], shas[-1], "-C", str(repo), "-k", "test_help_prints"]
    whole = cli("sil", "history", *common, "-o", str(tmp_path / "whole"), cache=tmp_path / "cache")
    assert whole.returncode == 0, whole.stdout[-3000:] + whole.stderr[-2000:]
    data = json.loads((tmp_path / "whole" / "history.json").read_text())
    assert [c["sha"] for c in data["commits"]] == shas
    assert [c["status"] for c in data["commits"]] == ["ran", "no-build", "ran", "ran"]
    assert data["commits"][1]["detail"].startswith("main.c: firmware-pico/main.c:"), data["commits"][1]
    assert set(data["commits"][0]["verdicts"].values()) == {"pass"}
    assert set(data["commits"][2]["verdicts"].values()) == {"fail"}     # R7's help text no longer
    page = (tmp_path / "whole" / "history.html").read_text()
    assert "test_commands::test_help_prints_the_synopsis_of_this_release[help]: pass -&gt; fail" in page
    for k in (1, 2):
        part = cli("sil", "history", *common, "--shard", f"{k}/2", "-o", str(tmp_path / f"part{k}"),
                   cache=tmp_path / "cache")
        assert part.returncode == 0, part.stdout[-3000:] + part.stderr[-2000:]
    merged = cli("sil", "history-merge", str(tmp_path / "part2"), str(tmp_path / "part1"),
                 "-o", str(tmp_path / "merged"), cache=tmp_path / "cache")
    assert merged.returncode == 0, merged.stdout + merged.stderr
    assert json.loads((tmp_path / "merged" / "history.json").read_text()) == data
    assert (tmp_path / "merged" / "history.html").read_text() == page
    # a part alone is refused as a whole
    alone = cli("sil", "history-merge", str(tmp_path / "part1"), "-o", str(tmp_path / "m2"),
                cache=tmp_path / "c")
    assert alone.returncode == 2 and "1/2 to 2/2, each once" in alone.stderr, alone.stderr

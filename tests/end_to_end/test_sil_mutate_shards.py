"""`sil mutate --shard K/N` and `sil mutate-merge` through the user's command: the two halves of a
seeded campaign, merged, give the whole campaign's page and JSON (the seconds each took aside)."""
import json
import re

import pytest
from sil_support import cli, firmware_tree

pytestmark = pytest.mark.timeout(1200)

CAMPAIGN = ["--count", "4", "--seed", "5", "-k", "test_commands", "--jobs", "1", "--killers-first", "none",
            "--plant", 'command.c:ostrnl(" V"):ostrnl(" v")']


def _effort_aside(summary):
    """The JSON without what depends on the machines, not on the campaign: seconds and how many
    control runs were made (each part makes its own)."""
    mutants = [dict(m, seconds=0) for m in summary["mutants"]]
    return dict(summary, seconds=0, controls=0, mutants=mutants)


@pytest.mark.slow
def test_two_shards_merged_are_the_whole_campaign(tmp_path):
    tree = str(firmware_tree())
    cache = tmp_path / "cache"
    whole = cli("sil", "mutate", tree, *CAMPAIGN, "-o", str(tmp_path / "whole"), cache=cache)
    assert whole.returncode == 0, whole.stdout[-3000:] + whole.stderr[-2000:]
    for k in (1, 2):
        part = cli("sil", "mutate", tree, *CAMPAIGN, "--shard", f"{k}/2", "-o", str(tmp_path / f"part{k}"),
                   cache=cache)
        assert part.returncode == 0, part.stdout[-3000:] + part.stderr[-2000:]
        assert f"part {k}/2" in part.stdout
        assert len(json.loads((tmp_path / f"part{k}" / "mutation.json").read_text())["mutants"]) < 5
    merged = cli("sil", "mutate-merge", str(tmp_path / "part2"), str(tmp_path / "part1" / "mutation.json"),
                 "-o", str(tmp_path / "merged"), cache=cache)
    assert merged.returncode == 0, merged.stdout + merged.stderr
    one = json.loads((tmp_path / "whole" / "mutation.json").read_text())
    two = json.loads((tmp_path / "merged" / "mutation.json").read_text())
    assert len(two["mutants"]) == 5 and [m["index"] for m in two["mutants"]] == list(range(5))
    assert _effort_aside(two) == _effort_aside(one)

    def page(folder):
        return re.sub(r"\d+ s\.", "N s.", (folder / "mutation.html").read_text())
    assert page(tmp_path / "merged") == page(tmp_path / "whole")


def test_a_bad_shard_is_one_line_exit_2(tmp_path):
    for shard in ("3/2", "0/2", "half", "1/0"):
        done = cli("sil", "mutate", str(firmware_tree()), "--count", "2", "--shard", shard,
                   "-o", str(tmp_path / "m"), cache=tmp_path / "cache")
        assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
        assert len(done.stderr.strip().splitlines()) == 1 and f"--shard {shard!r}" in done.stderr

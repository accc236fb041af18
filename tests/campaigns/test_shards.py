"""campaigns/shards.py: which mutants a part runs, and what the merge refuses or re-judges
(the parts here are JSON made by the test; the campaign end to end:
tests/end_to_end/test_sil_mutate_shards.py)."""
import re

import pytest

from buildhat_conformance.campaigns.shards import MergeError, merge, parse_shard, shard_of


def test_every_mutant_is_in_exactly_one_part():
    items = list("abcdefg")
    parts = [shard_of(items, k, 3) for k in (1, 2, 3)]
    assert parts[0] == ([0, 3, 6], ["a", "d", "g"])
    assert sorted(i for idx, _m in parts for i in idx) == list(range(7))


@pytest.mark.parametrize("text", ["0/2", "3/2", "1/0", "a/b", "1-2", ""])
def test_a_bad_shard_is_refused(text):
    with pytest.raises(ValueError, match="--shard"):
        parse_shard(text)


def _mutant(index, status="killed", cases=("test_a::one",)):
    return {"file": "main.c", "line": 10 + index, "offset": 100 + index, "kind": "planted", "original": "a",
            "replacement": "b", "function": "f", "status": status, "cases": list(cases), "requirements": [],
            "detail": "", "seconds": 1.0, "stopped_at_first_failure": True, "index": index}


def _part(shard, mutants, **over):
    part = {"tree": "/t", "seed": 1, "stop_at_first": True, "reference_cases": 3, "seconds": 2.0,
            "controls": 3, "unstable": [], "shard": shard, "mutants": mutants, "_path": f"part{shard}"}
    part.update(over)
    return part


def test_the_merge_puts_the_mutants_in_the_campaigns_order():
    campaign = merge([_part("2/2", [_mutant(1), _mutant(3)]), _part("1/2", [_mutant(0), _mutant(2)])])
    assert [o.mutant.line for o in campaign.outcomes] == [10, 11, 12, 13]
    assert campaign.seconds == 4.0 and campaign.controls == 6


def test_a_survivor_seen_only_in_a_case_another_part_found_varying_is_likely_equivalent():
    campaign = merge([_part("1/2", [_mutant(0, "survived", ["test_a::wobbly"])]),
                      _part("2/2", [_mutant(1, "survived", ["test_a::wobbly", "test_a::real"])],
                            unstable=["test_a::wobbly"])])
    assert [o.status for o in campaign.outcomes] == ["likely-equivalent", "survived"]
    assert campaign.outcomes[1].cases == ["test_a::real"] and campaign.unstable_cases == 1


@pytest.mark.parametrize("parts,says", [
    ([_part("1/2", [_mutant(0)])], "parts 2/2 missing"),
    ([_part("1/2", [_mutant(0)]), _part("1/2", [_mutant(0)])], "parts 2/2 missing"),
    ([_part("1/2", [_mutant(0)]), _part("2/3", [_mutant(1)])], "another split"),
    ([_part("1/2", [_mutant(0)]), _part("2/2", [_mutant(1)], seed=2)], "another campaign (seed 2"),
    ([_part("1/2", [_mutant(0)]), _part("2/2", [_mutant(0)])], "overlap or leave gaps"),
])
def test_parts_that_are_not_one_campaign_are_refused(parts, says):
    with pytest.raises(MergeError, match=re.escape(says)):
        merge(parts)





def test_a_whole_campaign_or_no_file_is_not_a_part(tmp_path):
    from buildhat_conformance.campaigns.shards import read_part
    whole = tmp_path / "mutation.json"
    whole.write_text('{"mutants": [], "seed": 1}')
    with pytest.raises(MergeError, match="not a part of a sil mutate campaign"):
        read_part(tmp_path)
    with pytest.raises(MergeError, match="no such file"):
        read_part(tmp_path / "nope.json")
    whole.write_text("{")
    with pytest.raises(MergeError, match="not the mutation.json of a sil mutate campaign"):
        read_part(whole)

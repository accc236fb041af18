"""The release profiles (protocol/profiles.py, profiles.json) must say what the facts (as
docs/FIRMWARE-BEHAVIOUR.md carries them) say."""

import behaviour_doc
import pytest

from buildhat_conformance.protocol import profiles


def test_seven_releases_in_order():
    nums = profiles.profile_numbers()
    assert nums == [1630165527, 1636109636, 1643737936, 1670332907, 1670596313, 1674818421, 1737564117]
    assert [profiles.get_profile(n).name for n in nums] == [f"R{i}" for i in range(1, 8)]


@pytest.mark.parametrize("name,nbytes,nlines", [("R1", 4136, 67), ("R4", 4136, 67), ("R5", 4293, 69),
                                                ("R6", 4201, 67), ("R7", 4201, 67)])
def test_help_text_sizes_match_facts(name, nbytes, nlines):
    # FIRMWARE-FACTS §4.3 gives the byte and line count of each help text.
    p = profiles.get_profile(name)
    assert len(p.help_lines) == nlines
    assert len(p.help_bytes) == nbytes


def test_version_strings_are_the_documents_releases():
    releases = behaviour_doc.section(behaviour_doc.text(), "fb-releases")
    for p in profiles.load_profiles().values():
        assert f"| {p.name} | {p.number} | `{p.version_string}` |" in releases


def test_help_texts_are_the_documents_blocks():
    texts = behaviour_doc.help_lines(behaviour_doc.text())
    for name, key in (("R1", "R1-R4"), ("R4", "R1-R4"), ("R5", "R5"), ("R6", "R6-R7"), ("R7", "R6-R7")):
        assert list(profiles.get_profile(name).help_lines) == texts[key], name


def test_command_tables_give_the_facts_shortest_prefixes():
    # FIRMWARE-FACTS §2: first match in table order; a few anchor cases per generation.
    def resolve(p, tok):
        return next((c for c in p.commands if c.startswith(tok)), None)
    r7, r1, r5 = (profiles.get_profile(n) for n in ("R7", "R1", "R5"))
    assert resolve(r7, "pid_") == "pid_diff" and resolve(r7, "pi") == "pid"
    assert resolve(r7, "b") is None and resolve(r1, "b") == "bias"
    assert resolve(r5, "selr") == "selrate" and resolve(r1, "selr") is None
    assert resolve(r1, "v") == "vin" and resolve(r1, "ve") == "version"


def test_unknown_version_uses_nearest_earlier():
    p, exact = profiles.resolve_version(1700000000)
    assert (p.name, exact) == ("R6", False)
    with pytest.raises(KeyError, match="known releases"):
        profiles.get_profile("1234")

"""campaigns/mutants.py: mutation sites of C code, seeded sampling, applying a mutant."""
from buildhat_conformance.campaigns.mutants import find_mutants, planted, sample

# C written for this test (not firmware code).
SOURCE = r'''
#include "x.h"
typedef unsigned char byte;
static int table[3] = {1, 2, 3};     // outside any function: left alone
int clamp(int v, byte*p) {
  if (v < 0 && v != -1) return 0;    /* a comment with < and && */
  print("Value: ok");
  v = v * 2 + 3;
  report(v);
  return v >= 10 || p == 0;
}
'''


def test_sites_of_each_kind(tmp_path):
    (tmp_path / "c.c").write_text(SOURCE)
    found = {(m.kind, m.original, m.replacement) for m in find_mutants(tmp_path, ["c.c"])}
    assert ("relational", "<", "<=") in found and ("relational", ">=", ">") in found
    assert ("relational", "!=", "==") in found and ("relational", "==", "!=") in found
    assert ("logical", "&&", "||") in found and ("logical", "||", "&&") in found
    assert ("arithmetic", "*", "/") in found and ("arithmetic", "+", "-") in found
    assert ("constant", "2", "1") in found and ("constant", "0", "1") in found
    assert ("string", "V", "v") in found
    assert ("call", 'print("Value: ok");', ";") in found and ("call", "report(v);", ";") in found
    # the pointer parameter, the comment, the #include and the table are no sites
    lines = {m.line for m in find_mutants(tmp_path, ["c.c"])}
    assert lines <= set(range(5, 12))
    assert not any(m.original == "*" and m.line == 5 for m in find_mutants(tmp_path, ["c.c"]))


def test_apply_changes_one_place_and_checks_the_tree(tmp_path):
    (tmp_path / "c.c").write_text(SOURCE)
    m = next(m for m in find_mutants(tmp_path, ["c.c"]) if m.kind == "logical" and m.original == "||")
    changed = m.apply(SOURCE)
    assert changed.count("&&") == SOURCE.count("&&") + 1 and len(changed) == len(SOURCE)
    assert m.function == "clamp"


def test_sampling_is_seeded_and_spreads_over_kinds(tmp_path):
    (tmp_path / "c.c").write_text(SOURCE)
    every = find_mutants(tmp_path, ["c.c"])
    a, b, c = sample(every, 6, 7), sample(every, 6, 7), sample(every, 6, 8)
    assert a == b and a != c
    assert len({m.kind for m in a}) == 6


def test_a_planted_mutant(tmp_path):
    (tmp_path / "c.c").write_text(SOURCE)
    m = planted(tmp_path, "c.c", "v * 2", "v * 3")
    assert m is not None and m.apply(SOURCE).count("v * 3") == 1 and m.line == 8


def test_two_plants_at_one_place_have_names_of_their_own(tmp_path):
    """A campaign keeps each mutant's run in a folder named by its ident: two plants that change
    one place differently ran in the same folder under --jobs 2, and one removed the other's."""
    (tmp_path / "c.c").write_text(SOURCE)
    a, b = planted(tmp_path, "c.c", "v * 2", "v / 2"), planted(tmp_path, "c.c", "v * 2", "v * 3")
    assert a is not None and b is not None and (a.offset, a.line) == (b.offset, b.line)
    assert a.ident != b.ident and a.ident.startswith("c-8-planted-")
    again = planted(tmp_path, "c.c", "v * 2", "v / 2")
    assert again is not None and again.ident == a.ident                 # the name is the change's
    sampled = next(m for m in find_mutants(tmp_path, ["c.c"]) if m.kind == "arithmetic" and m.original == "*")
    assert sampled.ident == f"c-{sampled.line}-arithmetic-{sampled.offset}"

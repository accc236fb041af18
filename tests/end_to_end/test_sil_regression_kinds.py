"""Three kinds of firmware regression the suite once let through (issue 34, item 6), each planted as a
single-site change in a copy of the R7 tree and run through the user's own command: the case written
for it fails on the planted tree and passes on the unplanted one."""
import pytest
from sil_support import cli, copy_tree, firmware_tree, junit_verdicts, plant  # noqa: E402

pytestmark = pytest.mark.timeout(900)

CASES = {
    # the report throttle: a report begun while the ring is full, not only while half of it is free
    "throttle": ("control.c", "return i<CTRLTXBLEN/2;", "return i<CTRLTXBLEN;",
                 "test_reports_beyond_the_wire_are_held_back_not_cut"),
    # the port-power-fault deglitch: more than 11 ms, not more than 10
    "deglitch": ("main.c", "gtimers[0]>10&&", "gtimers[0]>11&&", "test_port_power_fault_deglitch_boundary"),
    # a process variable's port: clamped to 0..4, one past the HAT's last
    "svar": ("command.c", "CLAMP(u,0,NPORTS-1);    sv->port", "CLAMP(u,0,NPORTS);    sv->port",
             "test_a_variable_the_hat_does_not_have_reads_its_last"),
}


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("silcache")


def run_cases(tree, junit, cache):
    done = cli("run", "--target", f"sil:{tree}", "-k", " or ".join(c[3] for c in CASES.values()),
               "--junit", str(junit), cache=cache)
    return done, junit_verdicts(junit)


@pytest.fixture(scope="module")
def unplanted(cache, tmp_path_factory):
    return run_cases(firmware_tree(), tmp_path_factory.mktemp("unplanted") / "junit.xml", cache)


@pytest.mark.parametrize("kind", sorted(CASES))
def test_a_planted_regression_of_each_kind_fails_its_case(kind, unplanted, cache, tmp_path):
    name, old, new, case = CASES[kind]
    done, verdicts = unplanted
    mine = [(n, v) for n, v, _m in verdicts if n.startswith(case)]
    assert done.returncode == 0 and mine and all(v == "pass" for _n, v in mine), (mine, done.stdout[-2000:])
    tree = copy_tree(tmp_path / "planted")
    plant(tree, name, old, new)
    done, verdicts = run_cases(tree, tmp_path / "junit.xml", cache)
    failed = [(n, m) for n, v, m in verdicts if v == "fail"]
    assert done.returncode == 1 and failed and all(n.startswith(case) for n, _m in failed), \
        (failed, done.stdout[-2000:])
    others = [(n, v) for n, v, _m in verdicts if not n.startswith(case)]
    assert all(v == "pass" for _n, v in others), others

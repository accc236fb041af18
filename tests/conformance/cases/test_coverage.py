"""Every requirement ID has a test; every known deviation is checked by some test; the data
table agrees with FIRMWARE-FACTS' release list."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import pytest
from repo_paths import REPO

from buildhat_conformance.conformance.deviations import deviations
from buildhat_conformance.protocol.profiles import load_profiles
from buildhat_conformance.protocol.requirements import requirement_ids

SUITE = REPO / "conformance" / "cases"


@pytest.fixture(scope="module")
def collected(tmp_path_factory: pytest.TempPathFactory) -> dict:
    tmp = tmp_path_factory.mktemp("collect")
    out = tmp / "ids.json"
    env = dict(os.environ, CONFORMANCE_IDS_OUT=str(out),
               PYTHONPATH=str(REPO / "tests" / "mutants") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "collect_ids",
                           "-p", "no:cacheprovider", "--import-mode=importlib", str(SUITE),
                           "--conformance-junit", str(tmp / "j.xml"), "--transcripts", str(tmp / "tr")],
                          cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=120)
    assert out.exists(), proc.stdout.decode()[-3000:]
    return json.loads(out.read_text())


def test_every_requirement_id_has_a_test(collected: dict) -> None:
    covered = {rid for ids in collected.values() for rid in ids}
    missing = [rid for rid in requirement_ids() if rid not in covered]
    assert not missing, f"requirement IDs without a test: {missing}"


def test_every_test_cites_known_ids(collected: dict) -> None:
    known = set(requirement_ids())
    for nodeid, ids in collected.items():
        assert ids, f"{nodeid} cites no requirement"
        bad = [i for i in ids if i not in known and not i.startswith("FW-")]
        assert not bad, f"{nodeid} cites unknown IDs {bad}"


def test_every_appendix_a_example_runs(collected: dict) -> None:
    examples = [rid for rid in requirement_ids() if rid.startswith("EX-")]
    by_id = {rid: [n for n, ids in collected.items() if rid in ids] for rid in examples}
    assert all(by_id.values()), {k: v for k, v in by_id.items() if not v}


def test_every_deviation_is_checked_by_a_test() -> None:
    source = "\n".join(p.read_text() for p in SUITE.glob("test_*.py"))
    for key, dev in deviations().items():
        assert re.search(rf'"{re.escape(key)}"', source), f"no test can report {key}"
        assert dev.requirement in requirement_ids(), f"{key} cites unknown {dev.requirement}"
        assert dev.profiles <= {p.name for p in load_profiles().values()}, key


def test_deviation_table_follows_the_release_features() -> None:
    # Cross-check the table against profiles.json, itself transcribed from FACTS §11.
    by_feature = {
        "BIAS-REMOVED": lambda p: "bias" not in p.commands,
        "PID-DOC-ARGS-REJECTED": lambda p: p.features["pid_numbers"] == 11,
        "SELONCE-VAR-REPEATS": lambda p: p.features["selonce_var_repeats"],
        "NO-DISCONNECTED-LINE": lambda p: not p.features["disconnected_line"],
        "PASSIVE-CONNECT-REPEATS": lambda p: p.features["passive_connect_repeats"],
        "PLIMIT-RESET-ON-EMPTY-PORT": lambda p: p.features["plimit_scope"] == "per_port",
        "UNWRAP-STATE-PERSISTS": lambda p: p.features["unwrap_init"] == "zero_persistent",
    }
    for key, rule in by_feature.items():
        expected = {p.name for p in load_profiles().values() if rule(p)}
        assert deviations()[key].profiles == expected, key

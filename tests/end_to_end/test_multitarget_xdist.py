"""Several targets at once (conformance/plugin/multitarget.py): one xdist worker per target, one
merged JUnit report that names the target of every case."""
from __future__ import annotations

import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from junit_props import properties, suite_properties

from buildhat_conformance.conformance.plugin.multitarget import (
    _repeated_targets,
    merge_junit,
    read_inventory,
)
from buildhat_conformance.conformance.runner import suite_dir

pytest.importorskip("xdist")


def test_inventory_lines_name_and_url(tmp_path) -> None:
    inv = tmp_path / "lab.txt"
    inv.write_text("# the lab\nbench-a  /dev/ttyUSB0   # by the window\n\nemulator:R5\n")
    assert read_inventory(str(inv)) == [("bench-a", "/dev/ttyUSB0"), ("target1", "emulator:R5")]


def test_inventory_rejects_repeated_names(tmp_path) -> None:
    inv = tmp_path / "lab.txt"
    inv.write_text("a emulator:R5\na emulator:R7\n")
    with pytest.raises(pytest.UsageError, match="unique"):
        read_inventory(str(inv))


def test_every_target_option_is_seen() -> None:
    args = ["-q", "--target", "emulator:R1", "--target=emulator:R7", "-k", "x", "--target", "/dev/ttyUSB0"]
    assert _repeated_targets(args) == ["emulator:R1", "emulator:R7", "/dev/ttyUSB0"]


def test_merge_prefixes_each_case_with_its_target(tmp_path) -> None:
    def part(name: str, outcome: str) -> str:
        path = tmp_path / f"{name}.xml"
        tag = "" if outcome == "pass" else "<failure message='x'>x</failure>"
        path.write_text("<testsuites><testsuite name='s' tests='1'><properties><property name='firmware' "
                        f"value='fw-{name}'/></properties><testcase classname='test_a' name='t' time='1.5'>"
                        f"{tag}</testcase></testsuite></testsuites>")
        return str(path)

    out = tmp_path / "merged.xml"
    n = merge_junit([("a", "emulator:R1", part("a", "pass")), ("b", "emulator:R7", part("b", "fail")),
                     ("c", "emulator:R5", str(tmp_path / "missing.xml"))], str(out))
    suite = ET.parse(out).getroot().find("testsuite")
    assert suite is not None
    assert n == 2 and suite.get("tests") == "2" and suite.get("failures") == "1"
    assert [tc.get("classname") for tc in suite.iter("testcase")] == ["a.test_a", "b.test_a"]
    props = suite_properties(suite)
    assert props["a:firmware"] == "fw-a" and props["missing:c"] == "emulator:R5"


@pytest.mark.slow
def test_three_emulator_targets_merge_into_one_report(tmp_path) -> None:
    inv = tmp_path / "lab.txt"
    # In virtual time: what is tested is the merge across workers, not the pty.
    inv.write_text("old inprocess:R1\nmid inprocess:R5\nnew inprocess:R7\n")
    junit = tmp_path / "junit.xml"
    argv = [sys.executable, "-m", "pytest", suite_dir(), "-p", "no:cacheprovider", "--rootdir", suite_dir(),
            "--import-mode=importlib", "-q", "--inventory", str(inv), "--conformance-junit", str(junit),
            "--transcripts", str(tmp_path / "tr"), "-k", "test_version_prints or test_four_ports"]
    # A bound against a hang, not a measurement: three pytest workers start on a possibly busy machine.
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=300, cwd=str(tmp_path))
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "conformance per target" in proc.stdout
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite is not None
    cases = list(suite.iter("testcase"))
    by_target = {}
    for tc in cases:
        props = properties(tc)
        assert tc.get("classname", "").startswith(props["target_name"] + ".")
        by_target.setdefault(props["target_name"], set()).add(props["profile"])
    # Every target ran every selected case, against its own firmware.
    assert by_target == {"old": {"R1"}, "mid": {"R5"}, "new": {"R7"}}
    assert len(cases) == 3 * len(cases) // 3 >= 6
    for name in ("old", "mid", "new"):
        assert os.listdir(tmp_path / "tr" / name)

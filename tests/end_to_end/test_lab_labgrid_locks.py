"""Issue 23: places of a real labgrid lab on loopback are held by one run at a time, and given back
on every way out (tests/lab_fixture.py: labgrid-coordinator, labgrid-exporter, ser2net, two
emulators as the HATs of places hat-a and hat-b, tagged board=buildhat).

Each run is the user's command, `buildhat-conformance run`, in a subprocess; who holds a place is
what `labgrid-client show` says. Skipped, with the reason, where labgrid or ser2net is missing.
"""
from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import time

import pytest
from lab_fixture import BIN, Lab, missing  # noqa: E402
from process_tree import cmdline, parents

SUBSET = "shortest_resolving_prefix"        # 28 short cases, about 13 s on a place
# Runs at real time, one after another: generous on a loaded machine (the suite's timing is make bench's).
pytestmark = pytest.mark.timeout(400)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    why = missing()
    if why:
        pytest.skip(why)
    lab = Lab(tmp_path_factory.mktemp("lab"), {"hat-a": [], "hat-b": []}).start()
    yield lab
    lab.stop()


def start_run(lab: Lab, tmp_path, name: str, *extra: str) -> subprocess.Popen:
    junit = tmp_path / name / "junit.xml"
    return subprocess.Popen([str(BIN / "buildhat-conformance"), "run", "-k", SUBSET, "--junit", str(junit),
                             *extra], env=lab.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


def wait_until(what, predicate, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < end, f"{what} did not happen in {timeout:g} s"
        time.sleep(0.2)


def finish(proc: subprocess.Popen) -> tuple:
    out, _ = proc.communicate(timeout=240)
    return proc.returncode, out


def test_a_second_run_on_a_held_place_says_so_or_waits_for_it(lab, tmp_path):
    first = start_run(lab, tmp_path, "first", "--target", "labgrid:hat-b")
    wait_until("the first run holding hat-b", lambda: lab.holder("hat-b") != "")
    second = subprocess.run([str(BIN / "buildhat-conformance"), "run", "--target", "labgrid:hat-b",
                             "-k", SUBSET, "--junit", str(tmp_path / "second" / "junit.xml")], env=lab.env,
                            capture_output=True, text=True, timeout=120)
    third = start_run(lab, tmp_path, "third", "--target", "labgrid:hat-b", "--lab-wait", "200")
    code1, out1 = finish(first)
    code3, out3 = finish(third)
    lines = [line for line in second.stderr.splitlines() if line.strip()]
    assert second.returncode == 3, second.stdout + second.stderr
    assert len(lines) == 1 and "place hat-b is held by another run on this machine" in lines[0], lines
    assert not (tmp_path / "second").exists()          # it touched nothing, the HAT least of all
    # Both runs that had the place pass every case: a byte of one reaching the other would fail
    # cases (the suite checks each reply line by line).
    assert code1 == 0, out1
    assert "waiting up to 200 s for place hat-b" in out3 and code3 == 0, out3
    assert lab.holder("hat-b") == ""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_run_gives_its_place_back(lab, tmp_path, sig):
    proc = start_run(lab, tmp_path, "run", "--target", "labgrid:hat-a")
    wait_until("the run holding hat-a", lambda: lab.holder("hat-a") != "")
    time.sleep(2)                       # into the cases
    proc.send_signal(sig)
    code, out = finish(proc)
    assert code == 130, out
    assert lab.holder("hat-a") == "", out


def _orphans_of(junit: pathlib.Path) -> list:
    """Every live process, whoever its parent, whose command line names ``junit``."""
    return [pid for pid in parents() if str(junit) in cmdline(pid)]


def test_a_place_left_by_a_killed_run_is_taken_back_by_the_next(lab, tmp_path):
    killed = start_run(lab, tmp_path, "killed", "--target", "labgrid:hat-a")
    wait_until("the run holding hat-a", lambda: lab.holder("hat-a") != "")
    time.sleep(2)
    killed.kill()
    killed.communicate(timeout=30)
    # its pytest child ends by the parent-death signal; the place stays acquired in labgrid
    wait_until("the killed run's child ending", lambda: not _orphans_of(tmp_path / "killed" / "junit.xml"))
    assert lab.holder("hat-a") != ""
    code, out = finish(start_run(lab, tmp_path, "next", "--target", "labgrid:hat-a"))
    assert "place hat-a was left acquired by a run that was killed" in out, out
    assert code == 0, out
    assert lab.holder("hat-a") == ""


def test_targets_lists_the_places_and_a_place_held_by_hand_stays_held(lab, tmp_path):
    lab.client("-p", "hat-a", "acquire")
    try:
        listing = subprocess.run([str(BIN / "buildhat-conformance"), "targets"], env=lab.env,
                                 capture_output=True, text=True, timeout=60)
        assert listing.returncode == 0, listing.stderr
        rows = {line.split()[0]: line for line in listing.stdout.splitlines()
                if line.startswith("  labgrid:")}
        assert "held by " in rows["labgrid:hat-a"] and "board=buildhat" in rows["labgrid:hat-a"], rows
        assert " free " in rows["labgrid:hat-b"], rows
        # This user acquired hat-a by hand: a run uses it and leaves it acquired.
        code, out = finish(start_run(lab, tmp_path, "byhand", "--target", "labgrid:hat-a", "-k",
                                     "shortest_resolving_prefix and ver"))
        assert code == 0, out
        assert lab.holder("hat-a") != ""
    finally:
        lab.client("-p", "hat-a", "release")


def test_fuzz_runs_one_campaign_per_place(lab, tmp_path):
    proc = subprocess.run([str(BIN / "buildhat-conformance"), "fuzz", "--places", "board=buildhat",
                           "--budget", "3s", "--seed", "1", "--quiet", "--out", str(tmp_path / "fuzz")],
                          env=lab.env, capture_output=True, text=True, timeout=240)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    for place in ("hat-a", "hat-b"):
        assert f"place {place}: no finding (exit 0)" in out, out
        assert (tmp_path / "fuzz" / place / "junit.xml").exists(), out
        assert lab.holder(place) == ""


def test_without_labgrid_a_labgrid_target_is_one_line(tmp_path):
    hidden = tmp_path / "nolabgrid" / "labgrid"
    hidden.mkdir(parents=True)
    (hidden / "__init__.py").write_text("raise ImportError(\"No module named 'labgrid'\")\n")
    env = dict(os.environ, PYTHONPATH=str(hidden.parent))
    proc = subprocess.run([str(BIN / "buildhat-conformance"), "run", "--target", "labgrid:hat-a"], env=env,
                          capture_output=True, text=True, timeout=60)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "needs labgrid: pip install 'labgrid>=24.0' (the lab extra" in lines[0]


def test_a_coordinator_nobody_runs_is_one_line(tmp_path):
    if not (BIN / "labgrid-coordinator").exists():
        pytest.skip("labgrid is not installed (the lab extra)")
    from lab_fixture import free_port

    proc = subprocess.run([str(BIN / "buildhat-conformance"), "run", "--target",
                           f"labgrid:hat-a?coordinator=127.0.0.1:{free_port()}"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=60)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 3 and len(lines) == 1, proc.stderr
    assert "cannot reach the labgrid coordinator at 127.0.0.1:" in lines[0]
    assert not (tmp_path / "reports").exists()

"""A user's profiles file (protocol/profile_file.py, docs/PROFILES.md; issue #33): a build the
package does not know, described as a release it starts from and what it changes, read by the one
loader (protocol/profiles.py) for this process and those it starts; every mistake is one line naming
the file and the key, and the command exits 2."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from buildhat_conformance.protocol import profiles
from buildhat_conformance.protocol.profile_file import ProfileFileError

BUILD = 1740000000


def _write(tmp_path, entries: dict) -> str:
    path = tmp_path / "builds.json"
    path.write_text(json.dumps({"profiles": entries}), encoding="utf-8")
    return str(path)


@pytest.fixture
def user_profiles():
    """Whatever a test loads is forgotten afterwards (the loader is cached per process)."""
    before = os.environ.pop(profiles.PROFILES_ENV, None)
    profiles.load_profiles.cache_clear()
    yield
    os.environ.pop(profiles.PROFILES_ENV, None)
    if before is not None:
        os.environ[profiles.PROFILES_ENV] = before
    profiles.load_profiles.cache_clear()


def test_a_build_starts_from_its_base_and_changes_what_it_says(tmp_path, user_profiles):
    r7 = profiles.get_profile("R7")
    help_text = [line.replace("dump firmware", "print firmware") for line in r7.help_lines]
    path = _write(tmp_path, {str(BUILD): {
        "base": "R7", "name": "R8-dev", "version_string": f"{BUILD} 2025-02-19T00:00:00+00:00",
        "help_text": help_text, "tx_throttle_reports": False}})
    profiles.use_profiles_file(path)
    build = profiles.get_profile("r8-dev")
    assert build.number == BUILD and build.base == "R7" and os.environ[profiles.PROFILES_ENV] == path
    assert build.help_lines == tuple(help_text) and build.help_lines != r7.help_lines
    assert build.commands == r7.commands and build.set_keywords == r7.set_keywords
    assert build.features["tx_throttle_reports"] is False and r7.features["tx_throttle_reports"] is True
    assert build.features["report_engine"] == r7.features["report_engine"]      # kept from R7
    assert build.signature is None                    # a signature is one image's: never inherited
    assert profiles.resolve_version(BUILD) == (build, True)
    assert profiles.neighbours(BUILD - 1) == (r7, build)


def test_every_mistake_is_one_line_naming_the_file_and_the_key(tmp_path, user_profiles):
    path = _write(tmp_path, {
        str(BUILD): {"base": "R9", "name": "R8-dev", "version_string": f"{BUILD} x", "colour": 3,
                     "tx_throttle_reports": "yes", "report_engine": "fast", "help_text": "one line"},
        "R8": {}, "1737564117": {"base": "R7", "name": "R7", "version_string": "1737564117 x"},
        "1750000000": {"base": "R7", "name": "late"}})
    with pytest.raises(ProfileFileError) as failed:
        profiles.use_profiles_file(path)
    lines = failed.value.lines
    assert all(line.startswith(f"{path}: profiles.") and "\n" not in line for line in lines)
    expected = {f"profiles.{BUILD}.base: unknown base 'R9'", f"profiles.{BUILD}.colour: unknown key",
                f"profiles.{BUILD}.tx_throttle_reports: wrong type: a string, where the releases have "
                "true or false",
                f"profiles.{BUILD}.report_engine: 'fast' is no behaviour the package models",
                f"profiles.{BUILD}.help_text: must be a list of strings",
                "profiles.R8: the key must be the build's version number",
                "profiles.1737564117: 1737564117 is a known release's number (R7)",
                "profiles.1737564117.name: 'R7' is a known release's name",
                "profiles.1750000000: missing `version_string`"}
    for want in expected:
        assert sum(want in line for line in lines) == 1, (want, lines)
    assert len(lines) == len(expected)
    assert profiles.PROFILES_ENV not in os.environ          # nothing was taken


def test_the_command_line_says_each_mistake_in_one_line_and_exits_2(tmp_path):
    path = _write(tmp_path, {str(BUILD): {"base": "R7", "name": "R8-dev", "version_string": f"{BUILD} x",
                                          "pid_numbers": "eleven"}})
    done = subprocess.run([sys.executable, "-m", "buildhat_conformance.cli", "targets", "--profiles", path],
                          capture_output=True, text=True, timeout=120,
                          env={k: v for k, v in os.environ.items() if k != profiles.PROFILES_ENV})
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [
        f"buildhat-conformance targets: {path}: profiles.{BUILD}.pid_numbers: wrong type: a string, where "
        "the releases have a whole number (e.g. 10)"]
    good = _write(tmp_path, {str(BUILD): {"base": "R7", "name": "R8-dev", "version_string": f"{BUILD} x"}})
    done = subprocess.run([sys.executable, "-m", "buildhat_conformance.cli", "targets", "--profiles", good],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and f"emulator:R8-dev {BUILD}" in done.stdout, done.stdout + done.stderr

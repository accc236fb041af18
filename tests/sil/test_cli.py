"""`buildhat-conformance sil ...`'s help as a newcomer meets it (issue 33): every action's --help works
and ends with its exit statuses, and `targets` lists the sil: URL's options."""
import re
import subprocess
import sys

import pytest

from buildhat_conformance.plumbing.cli_exits import EXIT_STATUSES
from buildhat_conformance.sil.target import _KNOWN

CLI = [sys.executable, "-m", "buildhat_conformance.cli"]


def run(*args):
    return subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=120)


def last_paragraph(text):
    return " ".join(text.strip().split("\n\n")[-1].split())


@pytest.mark.parametrize("action", ["build", "serve", "mutate", "coverage"])
def test_each_actions_help_ends_with_its_exit_statuses(action):
    done = run("sil", action, "--help")
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert done.stdout.startswith(f"usage: buildhat-conformance sil {action} ")
    closing = last_paragraph(done.stdout)
    assert closing.startswith("Exit status: 0 "), closing
    listed = {int(code) for code in re.findall(r"(?:^Exit status: |, )(\d+) ", closing)}
    assert listed == {code for code, _meaning in EXIT_STATUSES[f"sil {action}"]}, closing


@pytest.mark.parametrize("where", [["--help"], ["-h"], ["some-tree", "--pty", "--help"]])
def test_sil_serve_help_prints_serves_own_options(where):
    done = run("sil", "serve", *where)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage: buildhat-conformance sil serve ")
    for option in ("--pty", "--tcp", "--stdio", "--speed", "--control"):
        assert option in done.stdout, option


def test_sil_serve_alone_still_points_at_its_help():
    done = run("sil", "serve")
    assert done.returncode == 2 and "sil serve --help" in done.stderr


def test_targets_lists_every_option_of_the_sil_url():
    done = run("targets")
    assert done.returncode == 0, done.stderr
    listing = done.stdout.split("URL options", 1)[1]
    sil_rows = " ".join(line for line in listing.splitlines() if line.strip().startswith("sil:"))
    named = set(re.findall(r"(\w+)=", sil_rows))
    assert named == _KNOWN - {"boot"}, named     # boot= is booted='s older spelling

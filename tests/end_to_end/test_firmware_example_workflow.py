"""examples/github-actions-firmware.yml is run, not just read (issue 33): its buildhat-conformance command
lines use the spellings each command's --help shows, and its steps run as shell commands, as the runner
runs them, in a checkout whose firmware-pico/ is the R7 tree with a stray test program of its own main()
(as the firmware's history has them). Only the fuzz budgets are cut to one run each; the install step
is this checkout's own environment."""
from __future__ import annotations

import argparse
import importlib
import os
import pathlib
import re
import shlex
import subprocess
import sys
from typing import List

import pytest
import workflow_steps  # noqa: E402
from repo_paths import REPO  # noqa: E402
from sil_support import copy_tree  # noqa: E402

from buildhat_conformance import cli as cli_dispatch

WORKFLOW = REPO / "examples" / "github-actions-firmware.yml"
STRAY = '#include <stdio.h>\n#include "pico/stdlib.h"\nint main(void) {\n  stdio_init_all();\n' \
        '  printf("uart test\\n");\n  return 0;\n}\n'


def command_lines() -> List[List[str]]:
    """Every buildhat-conformance command line of the workflow, as words."""
    steps = workflow_steps.job_steps(WORKFLOW, "conformance")
    return [shlex.split(line)[1:] for script in steps.values() for line in script.splitlines()
            if line.strip().startswith("buildhat-conformance ")]


def _parser_of(words: List[str]) -> argparse.ArgumentParser:
    name = words[0]
    parser = cli_dispatch.command_parser(name, importlib.import_module(cli_dispatch.SUBCOMMANDS[name][0]))
    if name == "sil":       # the action's own parser
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        return sub.choices[words[1]]
    return parser


def test_every_command_line_uses_the_spellings_its_help_shows():
    lines = command_lines()
    assert len(lines) >= 6 and {w[0] for w in lines} == {"sil", "run", "fuzz"}, lines
    for words in lines:
        parser = _parser_of(words)
        shown = {option for action in parser._actions if action.help != argparse.SUPPRESS
                 for option in action.option_strings}
        for word in words:
            if word.startswith("-"):
                assert word.split("=")[0] in shown, f"{' '.join(words)}: {word} is not in its --help"
        parser.parse_known_args(words[2:] if words[0] == "sil" else words[1:])


def run_step(script: str, cwd: pathlib.Path, cache: pathlib.Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PATH=f"{pathlib.Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
               BUILDHAT_SIL_CACHE=str(cache))
    return subprocess.run(["bash", "-eo", "pipefail", "-c", script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=900)


@pytest.mark.slow
@pytest.mark.timeout(1800)
def test_the_steps_run_on_a_tree_with_a_stray_test_program(tmp_path: pathlib.Path):
    checkout = tmp_path / "checkout"
    tree = copy_tree(checkout / "firmware-pico")
    (tree / "test.c").write_text(STRAY)
    cache = tmp_path / "cache"          # a fresh runner: nothing built yet
    steps = workflow_steps.job_steps(WORKFLOW, "conformance")
    build = run_step(steps["Build this commit's firmware for the host"], checkout, cache)
    assert build.returncode == 0, build.stderr
    assert build.stdout.count("left out: test.c ") == 3, build.stdout
    suite = run_step(steps["The conformance suite, virtual time, with firmware coverage"], checkout, cache)
    assert suite.returncode == 0, suite.stdout[-2000:] + suite.stderr
    for name in ("A short fuzz campaign with sanitizers",
                 "A short fuzz campaign against the reference emulator"):
        script = re.sub(r"--budget \S+", "--budget 1x --seed 1", steps[name])
        fuzz = run_step(script, checkout, cache)
        # 0 no findings, 1 findings (what the campaign is for); never a usage error or a dead target
        assert fuzz.returncode in (0, 1), f"{name}: {fuzz.returncode}\n{fuzz.stdout[-2000:]}{fuzz.stderr}"
    published = re.search(r"path: \|\n((?:\s+\S+\n)+)", WORKFLOW.read_text())
    assert published is not None
    for path in published.group(1).split():
        assert (checkout / path).exists(), f"the upload step's {path} was not written"

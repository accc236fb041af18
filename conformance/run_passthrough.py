"""Which of ``buildhat-conformance run``'s unknown arguments go on to its pytest child.

pytest's options go after ``--`` (``run -t emulator -- -x --lf``), handed on untouched. Before
``--``, only the pytest options below (older scripts pass them there; they stay out of
``--help``) and test paths (``test_version.py``, ``test_x.py::test_y``) go on; anything else is
a mistake answered in one line like any bad option: a misspelt ``--targte emulator`` must not
start a pytest that answers with its usage text.
"""
from __future__ import annotations

import argparse
from typing import List

__all__ = ["PYTEST_OPTIONS", "refused_arguments", "UNKNOWN_ARGS_HINT", "PYTEST_HELP"]

UNKNOWN_ARGS_HINT = "pytest's own options go after --"
PYTEST_HELP = ("Options for pytest itself go after --, e.g. 'buildhat-conformance run -t emulator -- -x "
               "--lf'; test files and node ids may go either side.")

# pytest options accepted before `--`: name -> takes a value (as a separate argument or `=value`).
PYTEST_OPTIONS = {
    "-x": False, "--exitfirst": False, "-v": False, "--verbose": False, "-q": False, "--quiet": False,
    "-s": False, "-l": False, "--showlocals": False, "--collect-only": False, "--co": False,
    "--lf": False, "--last-failed": False, "--ff": False, "--failed-first": False, "--sw": False,
    "--stepwise": False, "--nf": False, "--new-first": False, "--pdb": False, "--trace": False,
    "--setup-show": False, "--no-header": False, "--no-summary": False, "--full-trace": False,
    "--strict-markers": False, "--runxfail": False, "--looponfail": False, "-f": False,
    "--maxfail": True, "--tb": True, "-r": True, "-p": True, "-m": True, "-n": True, "--numprocesses": True,
    "--dist": True, "--tx": True, "-d": False, "--durations": True, "-W": True, "--deselect": True,
    "--ignore": True, "--capture": True, "--color": True, "-o": True, "--override-ini": True,
    "--basetemp": True, "--log-level": True, "--timeout": True,
}
_FLAGS = {name[1] for name, takes in PYTEST_OPTIONS.items() if len(name) == 2 and not takes}


def _is_test_path(arg: str) -> bool:
    return "::" in arg or arg.split("::")[0].endswith(".py")


def refused_arguments(_args: argparse.Namespace, unknown: List[str]) -> List[str]:
    """The arguments before ``--`` that are neither a known pytest option (with its value) nor
    a test path: the ones to answer as a mistake."""
    refused: List[str] = []
    value_next = False
    for arg in unknown:
        if value_next:
            value_next = False
            continue
        if arg.startswith("--"):
            name, has_value = arg.split("=", 1)[0], "=" in arg
            if name not in PYTEST_OPTIONS:
                refused.append(arg)
            value_next = PYTEST_OPTIONS.get(name, False) and not has_value
        elif arg.startswith("-") and len(arg) > 1:
            if arg[:2] in PYTEST_OPTIONS and PYTEST_OPTIONS[arg[:2]]:
                value_next = len(arg) == 2          # -n 2, or -n2
            elif not all(c in _FLAGS for c in arg[1:]):   # -x, -vv, -xs
                refused.append(arg)
        elif not _is_test_path(arg):
            refused.append(arg)
    return refused

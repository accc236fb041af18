"""The exit statuses each command really returns, as data: every ``--help`` prints its own
line from here, and tests/cli/test_cli.py checks the statuses it sees against it.

The meanings are the project's contract (0 success, 1 the target failed the check, 2 the
user's mistake, 3 the target's fault); a command lists only the ones it can return.
"""
from __future__ import annotations

from typing import Dict, Tuple

__all__ = ["EXIT_STATUSES", "exit_status_help"]

_USAGE = "usage error (bad option, bad file, unknown release)"
_TARGET = "target unreachable, faulted or unable to do what was asked"
_STOPPED = "interrupted (Ctrl-C or SIGTERM)"
_CTRL_C = (130, "interrupted (Ctrl-C)")

# command -> ((status, meaning), ...). "buildhat-conformance" is the dispatcher itself.
EXIT_STATUSES: Dict[str, Tuple[Tuple[int, str], ...]] = {
    "buildhat-conformance": (
        (0, "success (conforms)"), (1, "conformance failures (fuzz: a finding; replay: a difference)"),
        (2, _USAGE), (3, _TARGET), _CTRL_C),
    "run": (
        (0, "conforms"), (1, "conformance failures (a fail, even if the target faulted later), or with "
                             "--expect-changes a case that differs from --baseline outside it"), (2, _USAGE),
        (3, "target unreachable or faulted (target faults or cases not run, and no failure), or the "
            "--baseline run left nothing to compare with"),
        (130, _STOPPED)),
    "script": ((0, "the script ran to its end"), (2, _USAGE),
               (3, "target unreachable, gone mid-run, or without what the script needs"), _CTRL_C),
    "targets": ((0, "listed"), (2, _USAGE), _CTRL_C),
    "fuzz": ((0, "no findings (with --reproduce: not reproduced)"),
             (1, "findings (with --reproduce: reproduced)"), (2, _USAGE), (3, _TARGET),
             (130, "interrupted (Ctrl-C or SIGTERM; what was found so far is written)")),
    "record": ((0, "recorded (with --proxy: the host program's own exit status)"), (2, _USAGE), (3, _TARGET),
               _CTRL_C),
    "replay": ((0, "what came back matches the recording"), (1, "it differs"), (2, _USAGE), (3, _TARGET),
               _CTRL_C),
    "mock": ((0, "served until stopped"), (1, "with --strict: the host departed from the recording"),
             (2, _USAGE)),       # Ctrl-C or SIGTERM stops serving: 0
    "report": ((0, "written (or listed, pruned)"), (1, "with --check: a JUnit file would trip CI readers"),
               (2, _USAGE), _CTRL_C),
    "load": ((0, "loaded and running"),
             (2, "usage error (bad option, bad file) or an image or signature the bootloader refuses"),
             (3, _TARGET), _CTRL_C),
    "rp2040": ((0, "rp2040js installed (or the URL would start)"), (2, _USAGE),
               (3, "Node.js, npm or the install is missing or failed; the URL's image, boot ROM or rp2040js "
                   "is missing"), _CTRL_C),
    "bench": ((0, "measured (a goal not met is in the table, not the status)"), (2, _USAGE), _CTRL_C),
    "sil": ((0, "built (or served until the host side ended, or coverage printed)"),
            (2, "usage error: not a firmware tree, a compile error, no C compiler, no coverage data"),
            (3, "sil serve: the firmware crashed, exited or never finished its start-up"), _CTRL_C),
    # sil's actions: each --help ends with its own (sil/cli.py)
    "sil build": ((0, "built (or up to date)"),
                  (2, "usage error: not a firmware tree, files that clash, a compile or link error, "
                      "no C compiler"), _CTRL_C),
    "sil serve": ((0, "the host side ended"),
                  (2, "usage error (bad option, not a firmware tree, a build error)"),
                  (3, "the firmware crashed, exited or never finished its start-up"),
                  (130, "interrupted (Ctrl-C); 143 after SIGTERM")),
    "sil mutate": ((0, "the campaign ran (survivors are in its report, not the status)"), (2, _USAGE),
                   (3, "the unmutated tree does not build or does not pass the suite"), _CTRL_C),
    "sil bisect": ((0, "the commit was found"),
                   (1, "nothing changed between GOOD and BAD, or only commits that do not build are left"),
                   (2, "usage error: not a repository, an unknown commit, GOOD not an ancestor of BAD, GOOD "
                       "does not build or runs no case"), _CTRL_C),
    "sil mutate-merge": ((0, "merged"), (2, "usage error: the parts do not make one campaign (a part missing "
                                            "or given twice, another seed or tree), or a file is not a part"),
                         _CTRL_C),
    "sil history": ((0, "every commit was tried (one that does not build is said, not an error)"),
                    (2, "usage error: not a repository, an unknown commit, FIRST not an ancestor of LAST, a "
                        "bad --shard"), _CTRL_C),
    "sil history-merge": ((0, "merged"), (2, "usage error: the parts do not make one history"), _CTRL_C),
    "sil coverage": ((0, "coverage printed (or cleared)"),
                     (2, "usage error: not a --coverage build, no counts yet, gcovr missing"), _CTRL_C),
    "buildhat-emulator": ((0, "the host side ended or the emulator was stopped"), (2, _USAGE),
                          (3, "with --strict-host: a host-lint finding"),
                          (130, "interrupted (Ctrl-C); 128+N after signal N (SIGTERM, SIGHUP)")),
}


def exit_status_help(command: str) -> str:
    """The ``--help`` line: ``Exit status: 0 ..., 2 ...``."""
    return "Exit status: " + ", ".join(f"{code} {meaning}" for code, meaning in EXIT_STATUSES[command]) + "."

"""What every command shares: the ``-t/--target`` option with its one default, the option
names and help texts used in more than one command (the option table of docs/USING.md), the exit
status values, and the one-line error for a user's mistake.

Exit statuses: 0 success / conforms, 1 conformance failures (or a finding reproduced), 2 usage
error (bad option, bad file, unknown release), 3 the target is unreachable, faulted, or cannot
do what was asked; which of them each command returns is plumbing/cli_exits.py.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Any, NoReturn, Optional

__all__ = ["EXIT_OK", "EXIT_FAILED", "EXIT_USAGE", "EXIT_TARGET", "DEFAULT_TARGET", "DEFAULT_SPEED",
           "BOOT_TIMEOUT_S", "TARGET_HELP", "RELEASE_HELP", "SPEED_HELP", "UsageError", "add_target_option",
           "add_hidden_alias", "expand_target", "OneLineParser", "check_writable"]

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_TARGET = 0, 1, 2, 3

DEFAULT_TARGET = "emulator"
DEFAULT_SPEED = 10.0
TARGET_HELP = ("target URL (default: emulator, which means emulator:latest?speed=10&fast_setup=1: the "
               "reference emulator, latest release, ten times real time, devices set up faster than a "
               "HAT's 2400 baud; add ?speed=1 for real time and the real set-up); "
               "'buildhat-conformance targets' lists the others")
# What --firmware takes, in every command that has it (protocol/profiles.py get_profile).
RELEASE_HELP = "R1..R7, a version number or latest"
# --speed means one thing everywhere: the HAT's clock runs N times real time.
SPEED_HELP = "the HAT's clock runs N times real time"
# --boot-timeout: seconds (HAT time) a booting target has to bring up its start-up layout
# (record and replay; a real HAT at real time with four devices needs several).
BOOT_TIMEOUT_S = 30.0


class UsageError(Exception):
    """A mistake in what the user asked for (exit status 2). The message is one line and
    names the file and line where there is one."""


def expand_target(url: str, speed: Optional[float] = DEFAULT_SPEED) -> str:
    """``emulator`` URLs that give no speed run at ``speed`` with the faster device set-up
    (``fast_setup=1`` unless the URL says; what the help text says the default target is);
    every other URL is returned unchanged."""
    url = url.strip()
    head = url.split(":", 1)[0].split("?", 1)[0]
    if head != "emulator" or not speed or "speed=" in url:
        return url
    if url == "emulator" or url.startswith("emulator?"):
        url = "emulator:latest" + url[len("emulator"):]   # the registry wants the release before a query
    url += ("&" if "?" in url else "?") + f"speed={speed:g}"
    return url if "fast_setup=" in url else url + "&fast_setup=1"


def add_target_option(parser: argparse.ArgumentParser, multiple: bool = False, extra_help: str = "") -> None:
    """``-t/--target URL`` with the one default. One target: the URL, expanded (an
    ``emulator`` URL without a speed gets the default speed). ``multiple``: a list, None when
    not given (``run`` passes the URLs on, with its own --speed)."""
    help_text = TARGET_HELP + (f"; {extra_help}" if extra_help else "")
    if multiple:
        parser.add_argument("-t", "--target", metavar="URL", action="append", default=None, help=help_text)
    else:
        parser.add_argument("-t", "--target", metavar="URL", type=expand_target, default=DEFAULT_TARGET,
                            help=help_text)


def add_hidden_alias(parser: argparse.ArgumentParser, *names: str, dest: str, **kwargs: Any) -> None:
    """An old spelling of an option that still works but is not shown in ``--help`` (docs/USING.md,
    "Options"): same ``dest``, no default of its own (the shown option's default stands)."""
    parser.add_argument(*names, dest=dest, help=argparse.SUPPRESS, default=argparse.SUPPRESS,
                        **kwargs)


def check_writable(path: str, what: str, folder: bool = False) -> None:
    """UsageError unless ``path`` (a file to write, or with ``folder`` a folder to write in;
    missing folders may be made) can be written. Tried for real (root passes every permission
    check) and undone: a refused run leaves the disk as it was."""
    import tempfile

    here = os.path.abspath(path)
    if not folder and os.path.isdir(here):
        raise UsageError(f"{what} {path}: is a folder, not a file")
    where = here if folder else os.path.dirname(here)
    made = []
    try:
        probe = where
        while not os.path.exists(probe):
            made.append(probe)
            probe = os.path.dirname(probe)
        for missing in reversed(made):
            os.mkdir(missing)
        with tempfile.TemporaryFile(dir=where):
            pass
        if not folder and os.path.exists(here) and not os.access(here, os.W_OK):
            raise PermissionError(13, "permission denied", here)
    except OSError as exc:
        raise UsageError(f"{what} {path}: {exc.strerror or exc}") from None
    finally:
        for created in made:
            try:
                os.rmdir(created)
            except OSError:
                pass


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a bad option in one line (``PROG: message (see PROG --help)``)
    with exit status 2, instead of the usage text followed by the error. Option names are
    never abbreviated: ``--version`` must not turn into ``--version-string``, nor a misspelt
    option into a neighbour's (nor, in ``run``, into one of pytest's)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{self.prog}: {message} (see {self.prog} --help)\n")
        sys.exit(EXIT_USAGE)

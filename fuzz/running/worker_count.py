"""How many campaign workers ``--jobs`` means (fuzz/running/workers.py runs them).

``--jobs auto``, the default, is a worker per CPU this process may use (at most
:data:`AUTO_JOBS_MAX`) when every target is a HAT this program starts itself (``inprocess``,
``emulator``, ``sil:``): a campaign on the firmware in the loop is bound by one core per worker,
so a second core doubles it. Anything else is one worker: a serial port or a socket is one HAT,
and a ``cmd:`` may be a user's bridge to one. ``$BUILDHAT_CONFORMANCE_JOBS`` says what ``auto``
means where fewer are wanted (a shared CI machine; the project's tests set 1).
"""
from __future__ import annotations

import argparse
import os
from typing import Union

from .target_kinds import OWN_SCHEMES, scheme

__all__ = ["AUTO_JOBS_MAX", "JOBS_ENV", "jobs_value", "auto_jobs", "resolve_jobs"]

AUTO_JOBS_MAX = 8                        # each worker starts targets of its own: a few processes each
JOBS_ENV = "BUILDHAT_CONFORMANCE_JOBS"


def jobs_value(text: str) -> Union[int, str]:
    """``--jobs``'s argument type: a number, or ``auto``."""
    if text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number of workers or 'auto', not {text!r}") from None


def _usable_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:               # (not Linux)
        return os.cpu_count() or 1


def auto_jobs(args: argparse.Namespace, default_target: str) -> int:
    """What ``--jobs auto`` means for ``args`` (``default_target``: the target without ``-t``)."""
    if getattr(args, "reproduce", None) or getattr(args, "places", None):
        return 1
    urls = [u for u in (args.target or default_target, getattr(args, "against", None)) if u]
    if not all(scheme(u) in OWN_SCHEMES for u in urls):
        return 1
    told = os.environ.get(JOBS_ENV, "").strip()
    if told:
        if not told.isdigit() or int(told) < 1:
            from ...plumbing.cli_options import UsageError

            raise UsageError(f"${JOBS_ENV} takes a positive number of workers, got {told!r}")
        return int(told)
    return max(1, min(_usable_cpus(), AUTO_JOBS_MAX))


def resolve_jobs(args: argparse.Namespace, default_target: str) -> int:
    """``args.jobs`` as a number (``auto`` resolved once, and remembered in ``args.jobs_auto``)."""
    jobs = getattr(args, "jobs", 1)
    if jobs == "auto":
        args.jobs, args.jobs_auto = auto_jobs(args, default_target), True
    return args.jobs if isinstance(getattr(args, "jobs", 1), int) else 1

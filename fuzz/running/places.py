"""``fuzz --places SPEC``: one campaign per labgrid place, all at once, findings per place.

The fuzzer drives one target per process, so each place gets its own ``buildhat-conformance
fuzz --target labgrid:PLACE --out OUT/PLACE`` child with the same options. This process holds
every place (harness/lab/selection.py) from before the first campaign to after the last, hands
them to the children, and gives them back on every way out. ``fuzz --target labgrid:PLACE``
alone is held the same way, for the campaign's whole life (it opens the target more than once).
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from typing import Callable, Dict, List, Optional

__all__ = ["hold_for_campaign", "run_places", "child_argv"]

# Options copied to every place's campaign: (attribute, flag); booleans are flags alone.
_PASSED = (("budget", "--budget"), ("seed", "--seed"), ("confirm", "--confirm"), ("profile", "--firmware"),
           ("families", "--families"), ("steps", "--steps"), ("batch", "--batch"), ("waits", "--waits"),
           ("fence_timeout", "--fence-timeout"), ("shrink_time", "--shrink-time"),
           ("check_time", "--check-time"), ("no_database", "--no-database"), ("quiet", "--quiet"))


def hold_for_campaign(args: argparse.Namespace) -> Optional[Callable[[], None]]:
    """Hold the places of ``--places`` or of a ``labgrid:`` target; the give-back, or None."""
    from ...harness.lab.selection import hold_places
    from ...plumbing.cli_options import UsageError

    if args.places and (args.target or args.against or args.reproduce or args.junit or args.database):
        raise UsageError("--places runs one campaign per place into --out/<place>/: it does not go with "
                         "--target, --against, --reproduce, --junit or --database")
    urls = [u for u in (args.target, args.against) if u]
    hold = hold_places(args.places, urls, args.lab_wait, args.coordinator)
    if hold is None:
        return None
    args.lab_hold = hold
    return hold.release


def child_argv(args: argparse.Namespace, url: str, out: str) -> List[str]:
    argv = [sys.executable, "-m", "buildhat_conformance.cli", "fuzz", "--target", url, "-o", out]
    for attr, flag in _PASSED:
        value = getattr(args, attr, None)
        if value is True:
            argv.append(flag)
        elif value not in (None, False):
            argv += [flag, str(value)]
    return argv


def run_places(args: argparse.Namespace) -> int:
    """One campaign per held place; one line each; the worst exit status (130, 2, 3, 1, 0)."""
    from ...plumbing.parent_death import die_with_parent

    places = args.lab_hold.places
    children: Dict[str, subprocess.Popen] = {}
    for name, url in places:
        out = os.path.join(args.out, name)
        # Made here, before the campaigns start: each child's check of its -o would otherwise make
        # and undo the shared parent at the same time as its siblings (a race that lost a campaign).
        os.makedirs(out, exist_ok=True)
        # Each campaign in a session of its own: a terminal's Ctrl-C reaches this process alone, which
        # passes it on once (SIGTERM, each campaign's Ctrl-C); a second would kill it
        # (fuzz/running/stop_signals.py).
        # The parent-death signal stops a campaign whose parent is gone, the same way.
        children[name] = subprocess.Popen(child_argv(args, url, out), start_new_session=True,
                                          preexec_fn=die_with_parent())
    print(f"fuzz: {len(children)} campaigns, one per labgrid place: {', '.join(children)}", flush=True)
    try:
        while any(p.poll() is None for p in children.values()):
            time.sleep(0.2)
    except KeyboardInterrupt:
        for proc in children.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in children.values():
            proc.wait()
    codes = {name: proc.returncode for name, proc in children.items()}
    for name, code in codes.items():
        what = {0: "no finding", 1: "findings", 2: "usage error", 3: "the target failed",
                130: "interrupted"}.get(code, f"exit status {code}")
        print(f"place {name}: {what} (exit {code}); results in {os.path.join(args.out, name)}")
    for worst in (130, 2, 3, 1):
        if worst in codes.values():
            return worst
    return max(codes.values(), default=0)

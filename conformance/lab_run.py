"""``run`` on labgrid places: hold them for the whole run, one worker each, give them back.

``--places SPEC`` (harness/lab/selection.py) becomes the run's targets: one place alone is the
run's ``--target``; several are an inventory named by place (conformance/plugin/multitarget.py: one
xdist worker each, one merged report whose every case names its place). ``labgrid:`` targets
given by hand are held the same way. The run holds its places from before the preflight to
after the report, so nothing else drives them in between, and releases them on every way out.
"""
from __future__ import annotations

import argparse
import os
import tempfile
from typing import Any, Callable, Optional

__all__ = ["hold_for_run"]


def hold_for_run(args: argparse.Namespace) -> Optional[Callable[[], None]]:
    """Hold the run's labgrid places and point ``args`` at them; returns the function that gives
    them back (None when the run uses no place). Raises UsageError / TargetError, one line."""
    from ..harness.lab.selection import hold_places
    from ..plumbing.cli_options import UsageError

    places = getattr(args, "places", None)
    targets = args.target if isinstance(args.target, list) else [args.target or ""]
    if places and getattr(args, "inventory", None):
        raise UsageError("--places and --inventory do not go together; give one of them")
    hold: Any = hold_places(places, [t for t in targets if t], getattr(args, "lab_wait", 0.0),
                            getattr(args, "coordinator", ""))
    if hold is None:
        return None
    inventory = ""
    if places:
        if len(hold.places) == 1:
            args.target = [hold.places[0][1]]
        else:
            fd, inventory = tempfile.mkstemp(prefix="buildhat-places-", suffix=".txt")
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.writelines(f"{name} {url}\n" for name, url in hold.places)
            args.inventory, args.target = inventory, [url for _n, url in hold.places]
        print("labgrid places: " + ", ".join(name for name, _u in hold.places), flush=True)

    def give_back() -> None:
        try:
            hold.release()
        finally:
            if inventory:
                os.unlink(inventory)
    return give_back

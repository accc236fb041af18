"""``buildhat-conformance fuzz --reproduce FINDING``: a finding's script replayed ``--confirm`` times
against the target (and the second target) it names, or those given; reproduced or not."""
from __future__ import annotations

import argparse
import re
from typing import Callable, Optional

from ...harness.targets.base import Target, TargetError
from ...transcripts.script import load_script
from ..running.from_arguments import DEFAULT_TARGET
from ..running.release import detect_profile, judged_profile
from ..running.target_kinds import is_fresh, is_virtual, opener_for, sides_rings
from .replay import replay_script

__all__ = ["reproduce"]


_HEADER = re.compile(r"^;; (target|against|release|began on): (.*)$", re.M)
_ORACLE_OF = re.compile(r"^fuzz finding \((\w+)\)")


def reproduce(args: argparse.Namespace, primary: Optional[Callable[[], Target]] = None,
              secondary: Optional[Callable[[], Target]] = None) -> int:
    """``--reproduce FINDING``: replay its script ``--confirm`` times (at least once)."""
    path = args.reproduce
    try:
        with open(path, encoding="utf-8") as fh:
            recorded = dict(_HEADER.findall(fh.read()))
        script = load_script(path)
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    target = args.target or recorded.get("target") or DEFAULT_TARGET
    against = args.against or recorded.get("against")
    fence_s = args.fence_timeout if args.fence_timeout is not None else (
        0.3 if is_virtual(target) else 2.0)
    open_primary = primary or opener_for(target)
    profile = judged_profile(open_primary, args.profile, fence_s)
    other = None
    if secondary is not None or against:
        open_secondary = secondary or opener_for(against or "")
        other = (open_secondary, detect_profile(open_secondary, fence_s))
    # A finding's script names its oracle; only that failure reproduces it (any, for other scripts).
    named = _ORACLE_OF.search(script.name or "")
    oracle = named.group(1) if named else None
    attempts = max(1, args.confirm)
    hits, first, others, refused = 0, None, [], []
    for _ in range(attempts):
        finding = replay_script(script, open_primary, profile, fence_s, fresh=is_fresh(target), against=other,
                                tx_ring=sides_rings(target, against, secondary))
        if finding is None:
            continue
        if finding.details.get("prelude"):
            refused.append(finding)           # the target did not take the prelude: proves nothing
        elif oracle is None or finding.oracle == oracle:
            hits += 1
            first = first or finding
        else:
            others.append(finding)
    where = f"{target}" + (f" against {against}" if against else "")
    if len(refused) == attempts:
        raise TargetError(f"could not replay on {where}: the target did not take the prelude "
                          f"({refused[0].message})")
    if first is not None:
        print(f"reproduced ({hits}/{attempts} replays) on {where}: [{first.oracle}] {first.message}")
    else:
        print(f"not reproduced (0/{attempts} replays) on {where}")
        if "began on" in recorded and is_fresh(target):
            print(f"  the finding began on {recorded['began on']}")
    for f in others[:1]:
        print(f"  {len(others)} replay(s) failed otherwise, first: [{f.oracle}] {f.message[:300]}")
    return 1 if first is not None else 0

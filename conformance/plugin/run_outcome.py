"""What a conformance run says as a whole: its one-word verdict with how much was skipped and why
(the banner), and whether it could do its job at all.

A run that could not do its job exits 3 with one line saying why (issue 24): every case skipped,
or a target judged by ``--firmware`` as a release other than the one it answers as.
"""
from __future__ import annotations

from collections import Counter
from typing import Iterable, Mapping, Optional, Tuple

from ...protocol.profiles import Profile, resolve_version
from ..verdict import FAIL, NOT_RUN, SKIP, TARGET_FAULT

#: node id -> (verdict class, requirement IDs), as conformance.plugin.Run keeps them
Results = Mapping[str, Tuple[str, object]]

__all__ = ["release_mismatch", "skip_cause", "banner", "nothing_done", "NO_CONTROL"]

NO_CONTROL = "no control channel"


def release_mismatch(url: str, version_string: Optional[str], judged: Profile) -> Optional[str]:
    """Why judging ``url`` by ``judged`` cannot work, or None. ``--firmware`` is for a build no
    release matches; a target that answers as a known release judged as another gets verdicts
    about firmware it does not run."""
    head = (version_string or "").split()[:1]
    if not head or not head[0].isdigit():
        return None
    runs, exact = resolve_version(int(head[0]))
    if not exact or runs.number == judged.number:
        return None
    return (f"{url} runs {runs.name} (firmware {head[0]}), not {judged.name} that --firmware judges it by: "
            "every verdict would be about a release it does not run; drop --firmware (it is for builds no "
            f"release matches) or run a {judged.name} target")


def skip_cause(reason: str, has_control: bool) -> str:
    """A short cause for a skip reason, for counting: a device or world action nobody could
    provide on a target without a control channel is that; otherwise the reason's head."""
    if reason.startswith("needs") and not has_control:
        return NO_CONTROL
    head = reason.split(":", 1)[0].strip()
    return head[:60] or "skipped"


def _skipped_part(reasons: Iterable[str], total: int, has_control: bool) -> str:
    causes = Counter(skip_cause(r, has_control) for r in reasons)
    n = sum(causes.values())
    if not n:
        return ""
    top = causes.most_common(2)
    why = top[0][0] if len(causes) == 1 else ", ".join(f"{c} {cause}" for cause, c in top) + \
        (f", {n - sum(c for _, c in top)} other" if len(causes) > 2 else "")
    return f" ({n} of {total} cases skipped: {why})"


def banner(results: Results, skip_reasons: Mapping[str, str], has_control: bool) -> str:
    """The run's verdict in a few words, e.g. ``CONFORMS (63 of 353 cases skipped: no control
    channel)``."""
    counts = Counter(cls for cls, _ in results.values())
    total = sum(counts.values())
    skipped = _skipped_part((skip_reasons.get(n, "") for n, (cls, _) in results.items() if cls == SKIP),
                            total, has_control)
    if counts[FAIL]:
        return f"FAILS: {counts[FAIL]} finding(s) against the protocol{skipped}"
    if counts[TARGET_FAULT] or counts[NOT_RUN]:
        return f"INCOMPLETE: the target faulted{skipped}"
    if total and counts[SKIP] == total:
        return f"NOTHING RAN{skipped}"
    return f"CONFORMS{skipped}"


def nothing_done(results: Results, skip_reasons: Mapping[str, str],
                 has_control: bool) -> Optional[str]:
    """One line when every case that was collected skipped (the run checked nothing), else None."""
    classes = [cls for cls, _ in results.values()]
    if not classes or any(cls != SKIP for cls in classes):
        return None
    return f"no case could run{_skipped_part(skip_reasons.values(), len(classes), has_control)}"

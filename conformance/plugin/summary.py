"""The terminal summary of a conformance run: verdicts per requirement area, the requirement IDs
no case covered, the target faults (and what a reset did), and what the target was judged as."""
from __future__ import annotations

from collections import defaultdict
from typing import Any, Dict

from ...protocol.requirements import requirements
from ..verdict import VERDICTS

__all__ = ["write_summary", "area_of", "firmware_of", "FW_AREA"]

FW_AREA = "Firmware facts (FW-)"


def area_of(req_id: str) -> str:
    if req_id.startswith("FW-"):
        return FW_AREA
    for r in requirements():
        if r.id == req_id:
            return r.area
    return "Unknown IDs"


def firmware_of(hat: Any) -> str:
    """What the target runs (its `version` answer); the profile it is judged as may differ."""
    return getattr(hat.session, "version_string", "") or hat.profile.version_string


def write_summary(tr: Any, run: Any) -> None:
    """Write the summary of ``run`` (a conformance.plugin.Run) on pytest's terminal reporter."""
    tr.section("conformance by requirement area")
    per_area: Dict[str, Dict[str, int]] = defaultdict(lambda: defaultdict(int))
    covered = set()
    for cls, ids in run.results.values():
        for rid in set(ids):
            covered.add(rid)
            per_area[area_of(rid)][cls] += 1
    classes = VERDICTS
    tr.write_line(f"{'area':<32}" + "".join(f"{c:>16}" for c in classes))
    areas = [r.area for r in requirements()]
    for area in sorted(per_area, key=lambda a: (areas.index(a) if a in areas else 99, a)):
        tr.write_line(f"{area:<32}" + "".join(f"{per_area[area][c]:>16}" for c in classes))
    all_ids = [r.id for r in requirements()]
    missing = [rid for rid in all_ids if rid not in covered]
    tr.write_line(f"requirement IDs with no test run: {len(missing)} of {len(all_ids)}"
                  + (f" ({', '.join(missing)})" if missing else ""))
    counts = {c: sum(1 for cls, _ in run.results.values() if cls == c) for c in VERDICTS}
    tr.write_line("verdicts: " + ", ".join(f"{counts[c]} {c}" for c in VERDICTS if counts[c]))
    for nodeid, what in run.target_faults[:20]:
        tr.write_line(f"  {nodeid}: {what}")
    if len(run.target_faults) > 20:
        tr.write_line(f"  ... and {len(run.target_faults) - 20} more target faults (JUnit has them all)")
    for text, failed in run.firmware.lines():
        tr.write_line(text, red=failed, yellow=not failed)
    hat = run.hat
    for line in (hat.clauses.broken() if hat is not None else []):
        tr.write_line(f"clause the harness relies on broke: {line}; its set-up went on without it", red=True)
    for line in (hat.setup_check.said if hat is not None else []):
        tr.write_line(line, yellow=True)
    if run.recovery.outcome:
        tr.write_line(run.recovery.outcome, yellow=True)
    if run.no_job:
        tr.write_line(f"the run could not do its job: {run.no_job}", yellow=True)
    elif run.stopped:
        tr.write_line(f"stopped talking to the target: {run.stopped}", yellow=True)
    if hat is not None:
        p = hat.profile
        exact = "" if hat.profile_exact else \
            f" ({hat.profile_why or 'unknown version'})"
        judged = " (--firmware)" if run.config.getoption("firmware") else ""
        tr.write_line(f"target {run.url}: firmware {firmware_of(hat)} judged as profile "
                      f"{p.name}{judged}{exact}")
    if run.seed is not None:
        tr.write_line(f"cases in a shuffled order, seed {run.seed} (the same order again: --random-order "
                      f"{run.seed})")
    tr.write_line(f"JUnit: {run.junit.path}   transcripts: {run.transcripts}")

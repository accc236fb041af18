"""`sil mutate`: how strong is the suite against the real firmware? Plant single-site changes
in a copy of a firmware tree (campaigns/mutants.py), build each with the stand-in (only the changed
file is compiled), run the suite against it in virtual time, and say per mutant what happened:

- ``killed``: a case failed (its name is kept): the suite defends that line. The mutant's run
  stops at its first failing case (``stopped``), which is all the verdict needs; with
  ``stop_at_first=False`` (``--all-cases``) every case runs and every failing one is listed;
- ``killed-by-fault``: only target faults (a crash, silence): caught, but not as a clause;
- ``survived``: every case passed although what the HAT sent differs from the original's
  (the cases that saw a difference, and their requirement IDs, are listed);
- ``likely-equivalent``: every case passed and, case by case, the HAT sent the original's
  answers and the original's asynchronous lines, each in the same order, as in the original's
  run of the same suite (the reference campaign); only where an asynchronous line fell among
  the answers may differ (conformance/case_output.py): no host can tell, as far as the suite looks.
  Cases whose output differs between runs of the original (when a host line reaches the HAT is
  paced partly by the wall clock, and a motor's state carries that into later cases) are left
  out of that comparison: a second run beside the reference, and a control run of the original
  among every ``CONTROL_EVERY`` mutants, under the load the mutants meet; so survivors and
  equivalent mutants are judged once the campaign's runs are done;
- ``no-build``, ``no-boot``: the mutant does not compile, or does not answer ``version``.

The score is killed / (all - likely-equivalent - no-build - no-boot). The firmware is
deterministic in virtual time, so the original's run is the reference for every mutant.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from ..conformance.case_output import PHASE_CONTROLS_NS, case_lines, read_verdicts, same_output
from ..sil.build import Build, BuildError, build_tree
from .mutants import Mutant

__all__ = ["Outcome", "Campaign", "run_campaign", "run_suite", "STATUSES", "CONTROL_EVERY",
           "PHASE_CONTROLS_NS"]

STATUSES = ("killed", "killed-by-fault", "survived", "likely-equivalent", "no-build", "no-boot")
#: One run of the unmutated tree among every this many mutants: the output that varies between
#: runs under the campaign's own load is learnt from these controls, not from its start alone.
CONTROL_EVERY = 30


@dataclass
class Outcome:
    mutant: Mutant
    status: str
    cases: List[str] = field(default_factory=list)       # killing cases, or cases that saw a difference
    requirements: List[str] = field(default_factory=list)
    detail: str = ""
    seconds: float = 0.0
    stopped: bool = False       # killed, and the run stopped at its first failing case

    def verdict_text(self) -> str:
        """What a reader is told beside the status: who killed it, or what else is known."""
        if self.status == "killed" and self.cases:
            return f"killed by {self.cases[0]}" + (" (the run stopped at the first failure)" if self.stopped
                                                   else "".join(f", {c}" for c in self.cases[1:3]) +
                                                   (f" and {len(self.cases) - 3} more" if len(self.cases) > 3
                                                    else ""))
        return ", ".join(self.cases[:3]) or self.detail


@dataclass
class Campaign:
    tree: str
    outcomes: List[Outcome]
    seconds: float
    reference_cases: int
    unstable_cases: int = 0      # cases whose output the runs of the unmutated tree do not agree on
    controls: int = 0            # runs of the unmutated tree besides the reference
    stop_at_first: bool = True   # a killed mutant's run stopped at its first failing case
    unstable: List[str] = field(default_factory=list)   # those cases (sil mutate-merge needs them)
    seed: Optional[int] = None   # the campaign's draw, and for a shard (--shard K/N) which part it is
    shard: str = ""
    indices: Optional[List[int]] = None   # each outcome's place in the whole campaign (default: its own)

    def count(self, status: str) -> int:
        return sum(1 for o in self.outcomes if o.status == status)

    @property
    def judged(self) -> int:
        return len(self.outcomes) - sum(self.count(s) for s in ("likely-equivalent", "no-build", "no-boot"))

    @property
    def score(self) -> Optional[float]:
        """Killed / judged in per cent; None when no mutant is left to judge (each one likely
        equivalent, not built or not booted): then there is no score, neither 0 nor NaN."""
        return 100.0 * self.count("killed") / self.judged if self.judged else None

    def score_text(self) -> str:
        score = self.score
        return f"{score:.1f}%" if score is not None else "none"

    def summary_line(self) -> str:
        parts = ", ".join(f"{self.count(s)} {s}" for s in STATUSES if self.count(s))
        return (f"mutation score {self.score_text()} ({self.count('killed')} killed by a failing case of "
                f"{self.judged} not likely equivalent); {len(self.outcomes)} mutants: {parts}; "
                f"{self.seconds:.0f} s" + (f"; {self.unstable_cases} case(s) left out of the comparison: "
                                           f"their output varies between {self.controls + 1} unmutated runs"
                                           f" ({_phases()})"
                                           if self.unstable_cases else "")
                + ("; each killed mutant's run stopped at its first failing case" if self.stop_at_first
                   else ""))

    def as_dict(self) -> dict:
        score = self.score
        return {"tree": self.tree, "score": None if score is None else round(score, 2), "judged": self.judged,
                "seconds": round(self.seconds, 1), "reference_cases": self.reference_cases,
                "unstable_cases": self.unstable_cases, "stop_at_first": self.stop_at_first,
                "unstable": self.unstable, "controls": self.controls, "seed": self.seed,
                **({"shard": self.shard} if self.shard else {}),
                "counts": {s: self.count(s) for s in STATUSES},
                "mutants": [dict(asdict(o.mutant), ident=o.mutant.ident, status=o.status, cases=o.cases,
                                 requirements=o.requirements, detail=o.detail, seconds=round(o.seconds, 1),
                                 stopped_at_first_failure=o.stopped, index=index)
                            for index, o in zip(self.indices or range(len(self.outcomes)), self.outcomes)]}


def _phases() -> str:
    shifts = " and ".join(f"{ns / 1000:g} us" for ns in PHASE_CONTROLS_NS)
    return f"{len(PHASE_CONTROLS_NS)} of them on a chip started {shifts} later"


def _command() -> List[str]:
    exe = os.path.join(os.path.dirname(sys.executable), "buildhat-conformance")
    return [exe] if os.path.exists(exe) else [sys.executable, "-m", "buildhat_conformance.cli"]


def _copy_tree(tree: Path, dest: Path) -> Path:
    dest.mkdir(parents=True)
    for p in tree.iterdir():
        if p.is_file():
            shutil.copyfile(p, dest / p.name)
    return dest


def run_suite(program: str, folder: Path, keyword: Optional[str], stop_at_first: bool = False,
              order: Optional[Path] = None, start_ns: int = 0, extra: Sequence[str] = ()) -> Tuple[int, Path]:
    """One run of the suite on a built program, its JUnit file, transcripts and log in ``folder``:
    (the run's exit status, the JUnit file). ``extra``: more options of ``run``."""
    junit = folder / "junit.xml"
    argv = _command() + ["run", "--target", f"sil:{program}", "--junit", str(junit),
                         "--transcripts", str(folder / "transcripts"), "--max-target-faults", "3", *extra]
    if keyword:
        argv += ["-k", keyword]
    # A target fault does not stop the run (pytest's -x would): a later case may still fail.
    argv += ["--", "-p", "buildhat_conformance.campaigns.first_failure_plugin"]
    argv += ["--stop-at-fail"] if stop_at_first else []
    argv += ["--case-order", str(order)] if order else []
    env = dict(os.environ, BUILDHAT_SIL_START_NS=str(start_ns)) if start_ns else None
    done = subprocess.run(argv, capture_output=True, text=True, timeout=1800, env=env)
    (folder / "run.log").write_text(done.stdout + done.stderr, encoding="utf-8")
    return done.returncode, junit


def _differences(reference: Dict[str, Tuple[List[str], List[str]]],
                 verdicts: List[Tuple[str, str, List[str], str]]) -> List[Tuple[str, List[str]]]:
    """The cases whose HAT output differs from the reference run's (conformance/case_output.py: an
    asynchronous line that only fell elsewhere among the answers is no difference), with their
    requirement IDs (only cases in ``reference``: those whose output the unmutated tree reproduces)."""
    lines = case_lines(verdicts)
    out = []
    for case, _verdict, reqs, _transcript in verdicts:
        ref = reference.get(case)
        if ref is not None and not same_output(ref[1], lines[case]):
            out.append((case, reqs))
    return out


def _one(mutant: Mutant, tree: Path, base: Build, work: Path, keyword: Optional[str],
         stop_at_first: bool = True, order: Optional[Path] = None) -> Outcome:
    """Build and run one mutant. One whose cases all passed comes back ``pending`` (its
    transcripts kept): survived or likely equivalent is decided once the controls have run."""
    t0 = time.monotonic()
    folder = work / "mutants" / mutant.ident
    if folder.exists():
        shutil.rmtree(folder)
    copy = _copy_tree(tree, folder / "tree")
    path = copy / mutant.file
    path.write_text(mutant.apply(path.read_text(encoding="utf-8", errors="replace")), encoding="utf-8")
    try:
        build = build_tree(str(copy), cache=work / "builds", base=base)
    except BuildError as exc:
        return Outcome(mutant, "no-build", detail=str(exc), seconds=time.monotonic() - t0)
    finally:
        shutil.rmtree(folder / "tree", ignore_errors=True)
    code, junit = run_suite(str(build.program), folder, keyword, stop_at_first, order)
    verdicts = read_verdicts(junit)
    failed = [c for c, v, _r, _t in verdicts if v == "fail"]
    reqs = sorted({r for c, v, rs, _t in verdicts if v == "fail" for r in rs})
    faults = [c for c, v, _r, _t in verdicts if v in ("target-fault", "not-run")]
    out: Outcome
    if failed:
        # --stop-at-fail ends the run after the first failing case; later ones are not in the JUnit file.
        out = Outcome(mutant, "killed", failed, reqs, stopped=stop_at_first)
    elif not verdicts:
        log = (folder / "run.log").read_text(encoding="utf-8", errors="replace").strip().splitlines()
        out = Outcome(mutant, "no-boot", detail=(log[-1] if log else f"run exited {code}"))
    elif faults:
        out = Outcome(mutant, "killed-by-fault", faults[:5])
    else:
        out = Outcome(mutant, "pending", detail=str(junit))
    if out.status in ("killed", "no-boot"):
        shutil.rmtree(folder / "transcripts", ignore_errors=True)   # keep what a developer reads
    shutil.rmtree(Path(build.folder), ignore_errors=True)
    out.seconds = time.monotonic() - t0
    return out


def _judge(out: Outcome, reference: Dict[str, Tuple[List[str], List[str]]]) -> None:
    """A pending mutant: survived (the cases whose lines differ) or likely equivalent."""
    junit = Path(out.detail)
    diff = _differences(reference, read_verdicts(junit))
    out.detail = ""
    if diff:
        out.status, out.cases = "survived", [c for c, _r in diff][:10]
        out.requirements = sorted({r for _c, rs in diff for r in rs})
    else:
        out.status = "likely-equivalent"
        shutil.rmtree(junit.parent / "transcripts", ignore_errors=True)


def _control(program: str, folder: Path, keyword: Optional[str],
             order: Optional[Path], start_ns: int = 0) -> Dict[str, List[str]]:
    """One run of the unmutated tree among the mutants (``start_ns``: a phase control): each
    case's HAT lines."""
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    _code, junit = run_suite(program, folder, keyword, False, order, start_ns)
    return case_lines(read_verdicts(junit))


Progress = Callable[[Outcome, int, int], None]


def run_campaign(tree: str, mutants: Sequence[Mutant], work: Path, jobs: int = 2,
                 keyword: Optional[str] = None, progress: Progress = lambda o, i, n: None,
                 stop_at_first: bool = True, killers_first: Sequence[str] = ()) -> Campaign:
    """Run ``mutants`` of ``tree``; ``work`` keeps the reference run and each survivor's transcripts.
    ``stop_at_first``: a mutant's run ends at its first failing case (the verdict is the same; a
    survivor or an equivalent mutant runs every case either way). ``killers_first``: cases
    (``module::case[param]``) every run of the campaign, the reference's too, runs first."""
    t0 = time.monotonic()
    work.mkdir(parents=True, exist_ok=True)
    base = build_tree(tree, cache=work / "builds")
    ref_folder = work / "reference"
    if ref_folder.exists():
        shutil.rmtree(ref_folder)
    ref_folder.mkdir()
    # What the HAT prints is fixed, but when the host's lines reach it is not quite (the harness
    # paces some waits by the wall clock, so load matters): two runs of the unmutated tree side
    # by side, as the mutants run, show the cases whose output varies anyway; a difference
    # there says nothing about a mutant.
    again_folder = ref_folder / "again"
    again_folder.mkdir()
    order: Optional[Path] = None
    if killers_first:
        order = work / "case-order.txt"
        order.write_text("".join(c + "\n" for c in killers_first), encoding="utf-8")
    with ThreadPoolExecutor(max_workers=2 if jobs > 1 else 1) as pool:
        first = pool.submit(run_suite, str(base.program), ref_folder, keyword, False, order)
        second = pool.submit(run_suite, str(base.program), again_folder, keyword, False, order)
        phases = [pool.submit(_control, str(base.program), work / "controls" / f"phase-{ns}ns", keyword,
                              order, ns) for ns in PHASE_CONTROLS_NS]
        code, junit = first.result()
        second.result()
    ref = read_verdicts(junit)
    bad = [c for c, v, _r, _t in ref if v in ("fail", "target-fault", "not-run")]
    if code not in (0,) or bad:
        raise RuntimeError(f"the unmutated tree does not pass the suite (exit {code}; "
                           f"{len(bad)} case(s) not passing, first: {bad[:1]}): mutants cannot be judged")
    ref_lines = case_lines(ref)
    runs = [case_lines(read_verdicts(again_folder / "junit.xml"))] + [p.result() for p in phases]
    outcomes: List[Outcome] = []
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = []
        controls = []
        for i, m in enumerate(mutants):
            if i and i % CONTROL_EVERY == 0:
                folder = work / "controls" / str(len(controls))
                controls.append(pool.submit(_control, str(base.program), folder, keyword, order))
            futures.append(pool.submit(_one, m, Path(base.tree), base, work, keyword, stop_at_first, order))
        for i, fut in enumerate(futures, 1):
            outcome = fut.result()
            outcomes.append(outcome)
            progress(outcome, i, len(futures))
        runs += [c.result() for c in controls]
    # The same measure as a mutant's: a case is left out when the unmutated runs differ by it.
    unstable = sorted(c for c in ref_lines
                      if any(c not in run or not same_output(ref_lines[c], run[c]) for run in runs))
    (ref_folder / "unstable-cases.txt").write_text("".join(c + "\n" for c in unstable), encoding="utf-8")
    reference = {c: (r, ref_lines[c]) for c, _v, r, _t in ref if c not in unstable}
    for i, outcome in enumerate(outcomes, 1):
        if outcome.status == "pending":
            _judge(outcome, reference)
            progress(outcome, i, len(outcomes))
    return Campaign(str(base.tree), outcomes, time.monotonic() - t0, len(ref), len(unstable),
                    controls=len(runs), stop_at_first=stop_at_first, unstable=unstable)

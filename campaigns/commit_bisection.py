"""`sil bisect GOOD BAD`: the first commit of a firmware repository's history where the selected
cases' verdicts (``output=True``: their HAT output) change from GOOD's.

The user's checkout is left as it is: each tried commit is checked out in a scratch git worktree
(``git worktree add --detach``: one stays at GOOD, one takes the commit tried; both removed at the
end), its firmware tree (``folder`` inside the repository) built with the stand-in, reusing GOOD's
objects for the files that did not change, and the suite run on it. The commits are BAD's
first-parent line back to GOOD (a merge counts as one commit). As ``git bisect`` does, BAD is taken
as changed without a build (it is built only when every commit before it turns out the same, to
confirm), so ten commits take at most five builds: GOOD's and four halvings. A commit whose tree does
not build (or that has no tree at ``folder``) is skipped, as ``git bisect skip`` does: the commit
nearest the middle is tried instead, and if only skipped commits are left between the last same and
the first changed one, all of them are named. A commit whose firmware does not answer counts as
changed (every verdict changed).

With ``output=True`` a case counts as changed when its HAT output differs from GOOD's by
conformance/case_output.py's measure; GOOD also runs as a chip started a little later (campaigns/mutation.py's
phase controls). A case whose answers move with that is left out; one whose answers stay but whose
asynchronous lines move (a ``deltat=`` stall line: a pass of 2-3 ms prints it or not as the 1 ms tick
falls, docs/FIRMWARE-BEHAVIOUR.md#fb-stall) is compared by its answers alone, as ``run --baseline``
counts such a difference as timing only (docs/COMPARING-BUILDS.md).
"""
from __future__ import annotations

import shutil
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from ..conformance.case_output import case_lines, moving_cases, read_verdicts, same_answers, same_output
from ..sil.build import Build, BuildError, build_tree
from .mutation import PHASE_CONTROLS_NS, run_suite

__all__ = ["BisectError", "Commit", "Step", "BisectResult", "bisect", "default_folder", "git",
           "resolve_commit", "first_parent_line"]


class BisectError(Exception):
    """A mistake in what was asked (not a repository, unknown commit, ...): one line."""


def git(repo: Path, *args: str) -> str:
    done = subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True)
    if done.returncode:
        lines = (done.stderr or done.stdout).strip().splitlines()
        raise BisectError(f"git {args[0]}: {lines[-1] if lines else f'exit {done.returncode}'}")
    return done.stdout.strip()


@dataclass(frozen=True)
class Commit:
    sha: str
    subject: str

    @property
    def short(self) -> str:
        return self.sha[:10]


@dataclass
class Step:
    commit: Commit
    status: str            # same, changed, skipped
    detail: str = ""       # the changed case, or why it was skipped


@dataclass
class BisectResult:
    good: Commit
    first: Optional[Commit]           # None: nothing changed up to BAD (or only skipped commits left)
    case: str = ""                    # the case that changed in it
    suspects: List[Commit] = field(default_factory=list)   # when skips leave several
    steps: List[Step] = field(default_factory=list)
    builds: int = 0


# A case's state at a commit: its verdict, or its HAT lines (output=True).
State = Dict[str, object]
Say = Callable[[str], None]


def default_folder(repo: Path, bad: str) -> str:
    """The firmware tree's folder in the repository: where the user stands in it, else
    ``firmware-pico`` when BAD has one, else the repository's root."""
    prefix = git(repo, "rev-parse", "--show-prefix").rstrip("/")
    if prefix:
        return prefix
    has = subprocess.run(["git", "-C", str(repo), "cat-file", "-e", f"{bad}:firmware-pico"],
                         capture_output=True).returncode == 0
    return "firmware-pico" if has else "."


def resolve_commit(repo: Path, ref: str, what: str) -> Commit:
    try:
        sha = git(repo, "rev-parse", "--verify", "--quiet", f"{ref}^{{commit}}")
    except BisectError:
        raise BisectError(f"{what} {ref!r}: not a commit of {repo}") from None
    return Commit(sha, git(repo, "log", "-1", "--format=%s", sha))


def first_parent_line(repo: Path, good: Commit, bad: Commit) -> List[Commit]:
    if subprocess.run(["git", "-C", str(repo), "merge-base", "--is-ancestor", good.sha, bad.sha],
                      capture_output=True).returncode != 0:
        raise BisectError(f"GOOD {good.short} is not an ancestor of BAD {bad.short}")
    out = git(repo, "log", "--first-parent", "--reverse", "--format=%H %s", f"{good.sha}..{bad.sha}")
    commits = [Commit(*(line.split(" ", 1) + [""])[:2]) for line in out.splitlines() if line]
    if not commits:
        raise BisectError(f"GOOD and BAD are the same commit ({good.short})")
    return commits


class _Tryer:
    """Builds and runs commits in the scratch worktree."""

    def __init__(self, repo: Path, scratch: Path, folder: str, work: Path, keyword: Optional[str],
                 extra: Sequence[str], output: bool):
        # GOOD stays checked out in its own worktree: a tried commit's files are compared with it
        # to reuse GOOD's objects (build_tree's base), so the tried commits need another.
        self.repo, self.scratch, self.folder, self.work = repo, scratch, folder, work
        self.keyword, self.extra, self.output = keyword, list(extra), output
        self.base: Optional[Build] = None
        self.builds = 0

    def build(self, commit: Commit) -> Build:
        where = self.scratch / ("good" if self.base is None else "tried")
        if where.exists():
            git(where, "checkout", "--quiet", "--force", "--detach", commit.sha)
        else:
            git(self.repo, "worktree", "add", "--quiet", "--detach", str(where), commit.sha)
        tree = where / self.folder
        if not tree.is_dir():
            raise BuildError(f"no folder {self.folder} in this commit")
        self.builds += 1
        build = build_tree(str(tree), base=self.base)
        self.base = self.base or build
        return build

    def state(self, build: Build, name: str, start_ns: int = 0) -> Tuple[State, str]:
        """Each selected case's verdict or output in one run; and the run's last line (for a
        run that left no cases)."""
        folder = self.work / name
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir(parents=True)
        code, junit = run_suite(str(build.program), folder, self.keyword, start_ns=start_ns, extra=self.extra)
        verdicts = read_verdicts(junit)
        log = (folder / "run.log").read_text(encoding="utf-8", errors="replace").strip().splitlines()
        why = log[-1] if log else f"run exited {code}"
        if self.output:
            return dict(case_lines(verdicts)), why
        return {case: verdict for case, verdict, _r, _t in verdicts}, why


def _changed(good: State, other: State, left_out: Sequence[str], output: bool,
             answers_only: Sequence[str] = ()) -> str:
    """The first case whose state differs from GOOD's, described; '' when none does (the cases in
    ``answers_only`` by their answers alone)."""
    for case, before in good.items():
        if case in left_out:
            continue
        after = other.get(case)
        if after is None:
            return f"{case}: did not run"
        if output:
            same = same_answers if case in answers_only else same_output
            if not same(before, after):   # type: ignore[arg-type]
                return f"{case}: its HAT output differs"
        elif after != before:
            return f"{case}: {before} -> {after}"
    new = [c for c in other if c not in good]
    return f"{new[0]}: runs here, not at GOOD" if new else ""


def bisect(repo: Path, good_ref: str, bad_ref: str, work: Path, folder: Optional[str] = None,
           keyword: Optional[str] = None, extra: Sequence[str] = (), output: bool = False,
           say: Say = print) -> BisectResult:
    """Find the first commit after GOOD up to BAD whose selected cases differ from GOOD's."""
    repo = Path(git(repo, "rev-parse", "--show-toplevel"))
    good, bad = resolve_commit(repo, good_ref, "GOOD"), resolve_commit(repo, bad_ref, "BAD")
    folder = folder or default_folder(repo, bad.sha)
    commits = first_parent_line(repo, good, bad)
    work.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix="bisect-", dir=work))
    try:
        return _search(_Tryer(repo, scratch, folder, work, keyword, extra, output), good, commits, say)
    finally:
        for name in ("good", "tried"):
            if (scratch / name).exists():
                subprocess.run(["git", "-C", str(repo), "worktree", "remove", "--force", str(scratch / name)],
                               capture_output=True)
        subprocess.run(["git", "-C", str(repo), "worktree", "prune"], capture_output=True)
        shutil.rmtree(scratch, ignore_errors=True)


def _search(tryer: _Tryer, good: Commit, commits: List[Commit], say: Say) -> BisectResult:
    result = BisectResult(good, None)
    try:
        build = tryer.build(good)
    except BuildError as exc:
        raise BisectError(f"GOOD {good.short} does not build: {exc}") from None
    runs = [("good", 0)] + ([(f"good-phase-{ns}ns", ns) for ns in PHASE_CONTROLS_NS] if tryer.output else [])
    with ThreadPoolExecutor(max_workers=2) as pool:
        states = list(pool.map(lambda r: tryer.state(build, r[0], r[1]), runs))
    reference, why = states[0]
    if not reference:
        raise BisectError(f"GOOD {good.short}: no case ran ({why}); check -k")
    left_out, answers_only = moving_cases(reference, [s for s, _w in states[1:]])  # type: ignore[arg-type]
    say(f"GOOD {good.short} {good.subject}: {len(reference)} case(s)"
        + (f", {len(left_out)} left out (their answers move with the chip's start)" if left_out else "")
        + (f", {len(answers_only)} compared by their answers alone (their asynchronous lines move with the"
           " chip's start)" if answers_only else "")
        + f"; {len(commits)} commit(s) up to BAD {commits[-1].short}")
    lo, hi = -1, len(commits) - 1            # lo: the last known same (GOOD), hi: the first known changed
    tried: Dict[int, Step] = {}
    changed_at: Dict[int, str] = {}

    def attempt(i: int) -> Step:
        commit = commits[i]
        try:
            built = tryer.build(commit)
        except BuildError as exc:
            said = str(exc).replace(f"{tryer.scratch}/tried/", "")     # the path in the repository
            step = Step(commit, "skipped", said.splitlines()[0] if said else "does not build")
        else:
            state, why = tryer.state(built, f"step-{len(tried) + 1}-{commit.short}")
            what = (_changed(reference, state, left_out, tryer.output, answers_only) if state
                    else f"no case ran ({why})")
            step = Step(commit, "changed" if what else "same", what)
            if what:
                changed_at[i] = what
        tried[i] = step
        result.steps.append(step)
        return step

    while True:
        open_ = [i for i in range(lo + 1, hi) if i not in tried]
        if not open_:
            break
        middle = (lo + hi) / 2
        i = min(open_, key=lambda j: (abs(j - middle), j))
        step = attempt(i)
        if step.status == "changed":
            hi = i
        elif step.status == "same":
            lo = i
        left = sum(1 for j in range(lo + 1, hi) if j not in tried)
        say(f"[{len(result.steps)}] {step.commit.short} {step.commit.subject}: {step.status}"
            + (f" ({step.detail})" if step.detail else "") + f"; {left} commit(s) left to try")
    if hi == len(commits) - 1 and hi not in tried:
        step = attempt(hi)               # BAD itself, taken as changed until now
        say(f"[{len(result.steps)}] {step.commit.short} {step.commit.subject} (BAD): {step.status}"
            + (f" ({step.detail})" if step.detail else ""))
        if step.status == "same":
            result.builds = tryer.builds
            return result
    result.first = commits[hi] if hi in changed_at else None
    result.case = changed_at.get(hi, "")
    result.suspects = [commits[j] for j in range(lo + 1, hi + 1)]
    result.builds = tryer.builds
    return result

"""One folder per run: ``reports/runs/<UTC timestamp>-<target>/`` holds that run's JUnit file,
transcripts and HTML report, so a run never mixes with an older one's files.

``reports/latest`` points at the newest run that ran cases (a symlink; a one-line text file
naming the folder where symlinks cannot be made), and ``reports/junit.xml`` and
``reports/index.html`` are copies of its files for CI steps that expect fixed paths. A run in
which nothing ran (``-k nosuchtest``, ``--collect-only``, a rejected node id) changes none of
them and leaves no folder behind.
"""
from __future__ import annotations

import argparse
import datetime
import os
import re
import shutil
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

__all__ = ["RunFolder", "RunInfo", "start", "finish", "cases_ran", "list_runs", "prune", "previous_junit",
           "resolve_latest", "start_for", "DEFAULT_ROOT"]

DEFAULT_ROOT = "reports"
RUNS = "runs"
LATEST = "latest"
_STAMP = "%Y%m%dT%H%M%SZ"
_NAME = re.compile(r"^(\d{8}T\d{6}Z)(?:-(.*))?$")


def _safe(text: str, limit: int = 60) -> str:
    """A target URL as part of a file name: ``emulator:R2?speed=10`` -> ``emulator_R2_speed_10``."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_.")[:limit] or "target"


def _target_name(target: str) -> str:
    """What names a target in a folder name: the URL, or for ``cmd:`` the program it runs
    (``cmd:python tests/planted/proxy.py wrong`` -> ``cmd-proxy``), not its whole command line; for
    ``labgrid:PLACE?...`` the place."""
    if target.startswith("labgrid:"):               # the place, not its coordinator's address
        return "labgrid-" + target[len("labgrid:"):].split("?", 1)[0]
    if not target.startswith("cmd:"):
        return target
    words = target[4:].split()
    prog = next((w for w in words[1:] if not w.startswith("-") and ("/" in w or "." in w)), words[0] if words
                else "cmd")
    return "cmd-" + os.path.splitext(os.path.basename(prog))[0]


@dataclass
class RunFolder:
    root: str          # the reports folder
    path: str          # root/runs/<name>

    @property
    def name(self) -> str:
        return os.path.basename(self.path)

    @property
    def junit(self) -> str:
        return os.path.join(self.path, "junit.xml")

    @property
    def html(self) -> str:
        return os.path.join(self.path, "index.html")

    @property
    def transcripts(self) -> str:
        return os.path.join(self.path, "transcripts")


def start(root: str, targets: Sequence[str], now: Optional[datetime.datetime] = None) -> RunFolder:
    """Make a new, empty run folder (a suffix keeps two runs in the same second apart)."""
    now = now or datetime.datetime.now(datetime.timezone.utc)
    base = f"{now.strftime(_STAMP)}-{_safe('+'.join(_target_name(t) for t in targets))}"
    runs = os.path.join(os.path.abspath(root), RUNS)
    os.makedirs(runs, exist_ok=True)
    for n in range(1, 1000):
        path = os.path.join(runs, base if n == 1 else f"{base}-{n}")
        try:
            os.mkdir(path)
            return RunFolder(os.path.abspath(root), path)
        except FileExistsError:
            continue
    raise OSError(f"cannot make a run folder under {runs}")


def _suite_info(junit: str) -> Optional[Dict[str, object]]:
    """Case count, verdict counts and target of a JUnit file; None when unreadable."""
    try:
        root = ET.parse(junit).getroot()
    except (OSError, ET.ParseError):
        return None
    counts: Dict[str, int] = {}
    cases = 0
    for tc in root.iter("testcase"):
        cases += 1
        verdict = ""
        for p in tc.iter("property"):
            if p.get("name") == "verdict":
                verdict = p.get("value") or ""
        if not verdict:
            verdict = ("fail" if tc.find("failure") is not None or tc.find("error") is not None
                       else "skip" if tc.find("skipped") is not None else "pass")
        counts[verdict] = counts.get(verdict, 0) + 1
    target = ""
    for suite in root.iter("testsuite"):
        props = suite.find("properties")
        for p in (props.findall("property") if props is not None else []):
            if p.get("name") == "target":
                target = p.get("value") or ""
        break
    return {"cases": cases, "counts": counts, "target": target}


def cases_ran(junit: str) -> bool:
    info = _suite_info(junit)
    return bool(info and info["cases"])


def _point_latest(root: str, folder: RunFolder) -> None:
    link = os.path.join(root, LATEST)
    rel = os.path.join(RUNS, folder.name)
    tmp = f"{link}.tmp{os.getpid()}"
    try:
        os.symlink(rel, tmp, target_is_directory=True)
        os.replace(tmp, link)
        return
    except OSError:
        # No symlinks here (some Windows setups, FAT): a text file naming the folder instead.
        if os.path.lexists(tmp):
            os.unlink(tmp)
    if os.path.isdir(link) and not os.path.islink(link):
        return       # a real folder called "latest" is the user's: leave it
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(rel + "\n")
    os.replace(tmp, link)


def resolve_latest(root: str = DEFAULT_ROOT) -> Optional[str]:
    """The folder ``reports/latest`` names (symlink or text file), or None."""
    link = os.path.join(root, LATEST)
    if os.path.islink(link) or os.path.isdir(link):
        path = os.path.realpath(link)
    elif os.path.isfile(link):
        with open(link, encoding="utf-8") as fh:
            path = os.path.join(root, fh.read().strip())
    else:
        return None
    return path if os.path.isdir(path) else None


def _retire_old_layout(root: str) -> None:
    """Before run folders, transcripts lived in ``reports/transcripts`` beside the JUnit file;
    move them (with that JUnit file) into a run folder of their own so they never stand beside
    a newer junit.xml. Nothing is deleted."""
    old = os.path.join(root, "transcripts")
    if not os.path.isdir(old):
        return
    stamp = datetime.datetime.fromtimestamp(os.path.getmtime(old), datetime.timezone.utc).strftime(_STAMP)
    dest = os.path.join(root, RUNS, f"{stamp}-earlier-layout")
    os.makedirs(dest, exist_ok=True)
    shutil.move(old, os.path.join(dest, "transcripts"))
    for name in ("junit.xml", "index.html"):
        src = os.path.join(root, name)
        if os.path.isfile(src):
            shutil.copy2(src, os.path.join(dest, name))


def _copy_atomic(src: str, dest: str) -> None:
    tmp = f"{dest}.tmp{os.getpid()}"
    shutil.copyfile(src, tmp)
    os.replace(tmp, dest)


def finish(folder: RunFolder) -> str:
    """After the suite: promote a run that ran cases (``latest`` and the well-known copies), or
    remove the folder of a run where nothing ran. Returns one line saying which."""
    root = folder.root
    if not cases_ran(folder.junit):
        # Nothing ran; the folder holds at most an empty JUnit file and an empty transcript
        # folder. Anything bigger (a between-cases transcript of a target that talked) is kept.
        leftovers = [os.path.join(d, f) for d, _s, files in os.walk(folder.path) for f in files
                     if not (os.path.join(d, f) == folder.junit
                             or os.path.getsize(os.path.join(d, f)) == 0)]
        if leftovers:
            return f"no test case ran; {folder.path} kept (it holds target output); reports/ left as it was"
        shutil.rmtree(folder.path, ignore_errors=True)
        return f"no test case ran; {root} left as it was"
    _retire_old_layout(root)
    _copy_atomic(folder.junit, os.path.join(root, "junit.xml"))
    html_copy = os.path.join(root, "index.html")
    if os.path.isfile(folder.html):
        _copy_atomic(folder.html, html_copy)
    elif os.path.isfile(html_copy):
        os.unlink(html_copy)      # an older run's report must not pass for this run's
    _point_latest(root, folder)
    return f"run folder: {folder.path} ({os.path.join(root, LATEST)} points at it)"


@dataclass
class RunInfo:
    name: str
    path: str
    target: str
    cases: int
    counts: Dict[str, int]
    latest: bool

    def line(self) -> str:
        counts = ", ".join(f"{n} {v}" for v, n in sorted(self.counts.items(), key=lambda kv: -kv[1]))
        mark = "  <- latest" if self.latest else ""
        return f"{self.name}  {self.target or '?'}  {self.cases} case(s): {counts or 'unreadable'}{mark}"


def list_runs(root: str = DEFAULT_ROOT) -> List[RunInfo]:
    """Every run folder, oldest first (names start with the UTC time they started)."""
    runs = os.path.join(root, RUNS)
    if not os.path.isdir(runs):
        return []
    latest = resolve_latest(root)
    out = []
    for name in sorted(os.listdir(runs)):
        path = os.path.join(runs, name)
        if not (os.path.isdir(path) and _NAME.match(name)):
            continue
        info = _suite_info(os.path.join(path, "junit.xml")) or {"cases": 0, "counts": {}, "target": ""}
        out.append(RunInfo(name, path, str(info["target"]), int(info["cases"]),  # type: ignore[arg-type]
                           dict(info["counts"]),  # type: ignore[arg-type]
                           latest is not None and os.path.realpath(path) == os.path.realpath(latest)))
    return out


def prune(root: str, keep: int) -> List[str]:
    """Delete all but the newest ``keep`` run folders (never the one ``latest`` names);
    returns the folders deleted."""
    if keep < 0:
        raise ValueError("--prune needs a number of runs to keep (0 or more)")
    runs = list_runs(root)
    doomed = [r for r in runs[:max(0, len(runs) - keep)] if not r.latest]
    for r in doomed:
        shutil.rmtree(r.path)
    return [r.path for r in doomed]


def previous_junit(junit: str) -> Optional[str]:
    """For a JUnit file inside a run folder, the JUnit file of the newest earlier run of the
    same target that ran cases; None when there is none (or the file is not in a run folder)."""
    folder = os.path.dirname(os.path.abspath(junit))
    runs = os.path.dirname(folder)
    me = os.path.basename(folder)
    if os.path.basename(runs) != RUNS or not _NAME.match(me):
        return None
    info = _suite_info(junit)
    target = info["target"] if info else ""
    for name in sorted(os.listdir(runs), reverse=True):
        if name >= me or not _NAME.match(name):
            continue
        cand = os.path.join(runs, name, "junit.xml")
        other = _suite_info(cand)
        if other and other["cases"] and other["target"] == target:
            return cand
    return None


def start_for(args: argparse.Namespace, root: str = DEFAULT_ROOT) -> Optional[RunFolder]:
    """``run``'s use: a new run folder, its JUnit and transcript paths set on ``args``; None (and
    ``args`` untouched) when ``--junit`` names the file, which then works as it always has."""
    if getattr(args, "junit", None):
        return None
    given = getattr(args, "target", None)
    targets = given if isinstance(given, list) else [given or "emulator"]
    folder = start(root, targets)
    args.junit = folder.junit
    if not getattr(args, "transcripts", None):
        args.transcripts = folder.transcripts
    return folder

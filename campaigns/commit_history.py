"""`sil history FIRST LAST`: the suite on every commit of a firmware repository's first-parent line
from FIRST to LAST (both included), each commit's tree built in a scratch git worktree (the user's
checkout untouched, as `sil bisect` does), one line per commit. ``--shard K/N`` runs every N-th
commit from the K-th, so a CI matrix spreads a long history over many runners; `sil history-merge`
makes one page and one JSON of the parts, the same as one run over every commit gives.

Per commit: ``ran`` (its verdicts per case), ``no-build`` (the build's one line) or ``no-boot`` (no
case ran; the run's last line). The page lists per commit its verdict counts and the cases whose
verdict changed since the commit before it that ran.
"""
from __future__ import annotations

import html
import json
import shutil
import subprocess
import tempfile
from collections import Counter
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from ..conformance.case_output import read_verdicts
from ..sil.build import BuildError, build_tree
from .commit_bisection import default_folder, first_parent_line, git, resolve_commit
from .mutation import run_suite
from .shards import MergeError, parse_shard, read_part, shard_of

__all__ = ["run_history", "merge_history", "write_history", "read_history_part"]

#: What makes two parts parts of one history run.
_SAME = ("repo", "first", "last", "folder", "keyword", "extra")


def run_history(repo: Path, first_ref: str, last_ref: str, work: Path, folder: Optional[str] = None,
                keyword: Optional[str] = None, extra: Sequence[str] = (), shard: Optional[str] = None,
                say: Callable[[str], None] = print) -> dict:
    repo = Path(git(repo, "rev-parse", "--show-toplevel"))
    first, last = resolve_commit(repo, first_ref, "FIRST"), resolve_commit(repo, last_ref, "LAST")
    folder = folder or default_folder(repo, last.sha)
    commits = [first] + (first_parent_line(repo, first, last) if first.sha != last.sha else [])
    indices = list(range(len(commits)))
    if shard:
        k, n = parse_shard(shard)
        indices, commits = shard_of(commits, k, n)
    work.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix="history-", dir=work)) / "tree"
    entries: List[dict] = []
    try:
        for place, (index, commit) in enumerate(zip(indices, commits), 1):
            if not scratch.exists():
                git(repo, "worktree", "add", "--quiet", "--detach", str(scratch), commit.sha)
            else:
                git(scratch, "checkout", "--quiet", "--force", "--detach", commit.sha)
            entry = {"index": index, "sha": commit.sha, "subject": commit.subject, "status": "ran",
                     "detail": "", "verdicts": {}}
            tree = scratch / folder
            try:
                if not tree.is_dir():
                    raise BuildError(f"no folder {folder} in this commit")
                build = build_tree(str(tree))
            except BuildError as exc:
                # the scratch worktree's path says nothing to the reader (and differs between parts)
                said = str(exc).replace(f"{scratch}/", "")
                entry.update(status="no-build", detail=(said.splitlines() or ["does not build"])[0])
            else:
                out = work / f"{index + 1:04d}-{commit.short}"
                if out.exists():
                    shutil.rmtree(out)
                out.mkdir(parents=True)
                code, junit = run_suite(str(build.program), out, keyword, extra=extra)
                entry["verdicts"] = {case: verdict for case, verdict, _r, _t in read_verdicts(junit)}
                if not entry["verdicts"]:
                    log = (out / "run.log").read_text(encoding="utf-8", errors="replace").strip().splitlines()
                    entry.update(status="no-boot", detail=log[-1] if log else f"run exited {code}")
            entries.append(entry)
            say(f"[{place}/{len(commits)}] {commit.short} {commit.subject}: {_counts_text(entry)}")
    finally:
        if scratch.exists():
            subprocess.run(["git", "-C", str(repo), "worktree", "remove", "--force", str(scratch)],
                           capture_output=True)
        subprocess.run(["git", "-C", str(repo), "worktree", "prune"], capture_output=True)
        shutil.rmtree(scratch.parent, ignore_errors=True)
    return {"repo": str(repo), "first": first.sha, "last": last.sha, "folder": folder, "keyword": keyword,
            "extra": list(extra), "commits_in_line": len(indices) if not shard else None,
            **({"shard": shard} if shard else {}), "commits": entries}


def _counts_text(entry: dict) -> str:
    if entry["status"] != "ran":
        return f"{entry['status']} ({entry['detail']})"
    counts = Counter(entry["verdicts"].values())
    return ", ".join(f"{n} {v}" for v, n in sorted(counts.items()))


def read_history_part(path: Path) -> dict:
    return read_part(path, "history.json", "commits", "a sil history run")


def merge_history(parts: Sequence[dict]) -> dict:
    """One history of every part (each exactly once): the commits in the line's order."""
    if not parts:
        raise MergeError("no parts to merge")
    splits: List[Tuple[int, int]] = [parse_shard(p["shard"]) for p in parts]
    n = splits[0][1]
    if any(total != n for _k, total in splits) or sorted(k for k, _n in splits) != list(range(1, n + 1)):
        raise MergeError(f"the parts are not 1/{n} to {n}/{n}, each once: "
                         f"{', '.join(p['shard'] for p in parts)}")
    for p in parts[1:]:
        for key in _SAME:
            if p.get(key) != parts[0].get(key):
                raise MergeError(f"{p['_path']}: another history ({key} {p.get(key)!r}, not "
                                 f"{parts[0].get(key)!r} as in {parts[0]['_path']})")
    commits = sorted((c for p in parts for c in p["commits"]), key=lambda c: c["index"])
    if [c["index"] for c in commits] != list(range(len(commits))):
        raise MergeError("the parts' commits do not make one history (their places overlap or leave gaps)")
    return {**{k: parts[0][k] for k in _SAME}, "commits_in_line": len(commits), "commits": commits}


def _changes(commits: Sequence[dict]) -> Dict[int, List[str]]:
    """Per commit that ran, the cases whose verdict differs from the last commit before it that ran."""
    out: Dict[int, List[str]] = {}
    before: Optional[Dict[str, str]] = None
    for c in commits:
        if c["status"] != "ran":
            continue
        now = c["verdicts"]
        if before is not None:
            out[c["index"]] = [f"{case}: {before.get(case, '(not run)')} -> {v}" for case, v in now.items()
                               if before.get(case) != v]
            out[c["index"]] += [f"{case}: {v} -> (not run)" for case, v in before.items() if case not in now]
        before = now
    return out


def write_history(data: dict, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "history.json").write_text(json.dumps(data, indent=1), encoding="utf-8")
    changes = _changes(data["commits"])
    rows = "".join(
        f"<tr><td><code>{html.escape(c['sha'][:10])}</code></td><td>{html.escape(c['subject'])}</td>"
        f"<td>{html.escape(_counts_text(c))}</td><td>"
        + "<br>".join(html.escape(x) for x in changes.get(c["index"], [])) + "</td></tr>"
        for c in data["commits"])
    what = f" (-k {html.escape(data['keyword'])})" if data.get("keyword") else ""
    page = ("<!doctype html><meta charset='utf-8'><title>The suite over a history</title>"
            "<style>body{font:14px/1.4 system-ui,sans-serif;margin:1.5em}table{border-collapse:collapse}"
            "td,th{border-bottom:1px solid #ddd;padding:4px 6px;text-align:left;vertical-align:top}</style>"
            f"<h1>The suite{what} over {len(data['commits'])} commit(s)</h1>"
            f"<p>{html.escape(data['repo'])}, folder {html.escape(data['folder'])}: "
            f"{html.escape(data['first'][:10])} to {html.escape(data['last'][:10])}, first-parent line.</p>"
            "<table><tr><th>commit</th><th>subject</th><th>verdicts</th>"
            "<th>changed since the commit before that ran</th></tr>" + rows + "</table>")
    path = folder / "history.html"
    path.write_text(page, encoding="utf-8")
    return path


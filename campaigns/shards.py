"""A `sil mutate` campaign spread over machines: ``--shard K/N`` runs the K-th of N parts of the
seeded campaign (every N-th mutant of the draw, from the K-th on), and ``sil mutate-merge`` makes
one campaign of the parts' ``mutation.json`` files, for one page and one JSON.

Each part runs its own reference and control runs of the unmutated tree (it is judged on its own
machine, under its own load). The merge lists the mutants in the whole campaign's order; a case one
part's controls found varying is left out for every part: a survivor seen only in such cases becomes
likely equivalent, as it would have in one campaign. Seconds and control runs add up.
"""
from __future__ import annotations

import json
import re
from dataclasses import fields
from pathlib import Path
from typing import List, Sequence, Tuple, TypeVar

from .mutants import Mutant
from .mutation import Campaign, Outcome

__all__ = ["MergeError", "parse_shard", "shard_of", "read_part", "merge"]

T = TypeVar("T")
_SHARD = re.compile(r"^(\d+)/(\d+)$")
#: A survivor's JSON keeps its first ten cases; one with that many may have more, unseen.
_CASES_KEPT = 10


class MergeError(Exception):
    """Parts that do not make one campaign: one line."""


def parse_shard(text: str) -> Tuple[int, int]:
    """``K/N`` with 1 <= K <= N; ValueError saying what is wrong."""
    found = _SHARD.match(text.strip())
    if not found:
        raise ValueError(f"--shard {text!r}: give K/N, e.g. 1/4")
    k, n = int(found.group(1)), int(found.group(2))
    if not 1 <= k <= n:
        raise ValueError(f"--shard {text!r}: K is 1 to N")
    return k, n


def shard_of(items: Sequence[T], k: int, n: int) -> Tuple[List[int], List[T]]:
    """The K-th of N parts: (their places in ``items``, the items)."""
    indices = list(range(k - 1, len(items), n))
    return indices, [items[i] for i in indices]


def read_part(path: Path, file_name: str = "mutation.json", items: str = "mutants",
              what: str = "a sil mutate campaign") -> dict:
    """A part's JSON (``file_name``, or the folder that holds one), which lists its ``items``."""
    path = path / file_name if path.is_dir() else path
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MergeError(f"{path}: no such file") from None
    except (OSError, ValueError) as exc:
        raise MergeError(f"{path}: not the {file_name} of {what} ({exc})") from None
    if not isinstance(data, dict) or items not in data:
        raise MergeError(f"{path}: not the {file_name} of {what} (no {items})")
    if not data.get("shard"):
        raise MergeError(f"{path}: not a part of {what} (run it with --shard K/N)")
    data["_path"] = str(path)
    return data


def _outcome(m: dict) -> Outcome:
    mutant = Mutant(**{f.name: m[f.name] for f in fields(Mutant)})
    return Outcome(mutant, m["status"], list(m.get("cases", [])), list(m.get("requirements", [])),
                   m.get("detail", ""), float(m.get("seconds", 0.0)), bool(m.get("stopped_at_first_failure")))


def merge(parts: Sequence[dict]) -> Campaign:
    """One campaign of every part of a sharded one (each exactly once)."""
    if not parts:
        raise MergeError("no parts to merge")
    shards = [parse_shard(p["shard"]) for p in parts]
    n = shards[0][1]
    for p, (k, total) in zip(parts, shards):
        if total != n:
            raise MergeError(f"{p['_path']}: part {k}/{total} of another split than {n} parts")
    seen = sorted(k for k, _n in shards)
    if seen != list(range(1, n + 1)):
        missing = sorted(set(range(1, n + 1)) - set(seen))
        twice = sorted({k for k in seen if seen.count(k) > 1})
        raise MergeError(f"parts {', '.join(f'{k}/{n}' for k in missing)} missing" if missing
                         else f"part {twice[0]}/{n} given twice")
    first = parts[0]
    for p in parts[1:]:
        for key in ("tree", "seed", "stop_at_first", "reference_cases"):
            if p.get(key) != first.get(key):
                raise MergeError(f"{p['_path']}: another campaign ({key} {p.get(key)!r}, not "
                                 f"{first.get(key)!r} as in {first['_path']})")
    placed = sorted((m["index"], m) for p in parts for m in p["mutants"])
    indices = [i for i, _m in placed]
    if indices != list(range(len(indices))):
        raise MergeError("the parts' mutants do not make one campaign (their places overlap or leave gaps)")
    unstable = sorted({c for p in parts for c in p.get("unstable", [])})
    outcomes = [_outcome(m) for _i, m in placed]
    for o in outcomes:
        if o.status == "survived" and len(o.cases) < _CASES_KEPT:
            o.cases = [c for c in o.cases if c not in unstable]
            if not o.cases:
                o.status, o.requirements = "likely-equivalent", []
    return Campaign(first["tree"], outcomes, sum(float(p.get("seconds", 0)) for p in parts),
                    int(first["reference_cases"]), len(unstable),
                    controls=sum(int(p.get("controls", 0)) for p in parts),
                    stop_at_first=first["stop_at_first"],
                    unstable=unstable, seed=first.get("seed"))

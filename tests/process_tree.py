"""The processes a command started, from /proc: every descendant of a pid (children of children
too, whatever session or process group they moved to), and which of them are still alive."""
from __future__ import annotations

import os
import time
from typing import Dict, Set


def parents() -> Dict[int, int]:
    """pid -> parent pid of every live (not zombie) process."""
    out = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", encoding="utf-8") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if fields[0] != "Z":
            out[int(name)] = int(fields[1])
    return out


def descendants(root: int) -> Set[int]:
    tree = parents()
    found: Set[int] = set()
    todo = [root]
    while todo:
        parent = todo.pop()
        for pid, ppid in tree.items():
            if ppid == parent and pid not in found:
                found.add(pid)
                todo.append(pid)
    return found


def cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            return fh.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def alive(pids: Set[int]) -> Set[int]:
    live = parents()
    return {p for p in pids if p in live}


def left_after(pids: Set[int], grace: float) -> Dict[int, str]:
    """Those of ``pids`` still running ``grace`` seconds from now (or as soon as none is)."""
    end = time.monotonic() + grace
    while alive(pids) and time.monotonic() < end:
        time.sleep(0.1)
    return {p: cmdline(p) for p in alive(pids)}

"""``--jobs N``: N campaign workers at once, one summary.

Each worker is a process of its own (forked, so the campaign's openers come along) with targets
of its own: worker w of N takes the run indexes w, w+N, w+2N ... of the campaign seed, so every
run is the run a single campaign would draw at that index, and ``--budget 500x --jobs 2`` runs
the same 500 runs as ``--budget 500x``. A time budget is each worker's. Each worker confirms and
reduces its own findings; the merge keeps one finding per oracle (the lowest worker's; the others
count as seen again), and adds up the figures. Only worker 0 replays the stored failing runs.

It needs a target started anew at every open (``inprocess``, ``emulator``, ``cmd:``, ``sil:``):
a HAT on a serial port or a socket is one HAT (for several, ``--places``).

Stopping: a worker ignores SIGINT (a terminal's Ctrl-C reaches the whole process group) and takes
SIGTERM from this process as its Ctrl-C (fuzz/running/stop_signals.py): the first Ctrl-C or SIGTERM here
is passed on to every worker, which keeps what it found, closes its targets and sends its result,
and what they ran is still merged; a second one kills the workers at once. A worker dies with this
process (its parent-death signal), and its targets with it.
"""
from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
import signal
import time
import traceback
from contextlib import nullcontext
from dataclasses import fields, replace
from typing import Any, Callable, Dict, List, Optional, Tuple

from ...harness.targets.base import TargetError, release_process_resources
from ...plumbing.parent_death import set_parent_death_signal
from .campaign import Budget, CampaignConfig, CampaignResult, not_done, run_campaign
from .checked_run import Stats
from .stop_signals import EXIT_INTERRUPTED, StopSignals

__all__ = ["run_jobs", "merge_stats", "merge_results", "PROGRESS_EVERY_S"]

PROGRESS_EVERY_S = 0.5      # how often a worker sends its figures for the progress line


def _plain(stats: Stats) -> Stats:
    """The figures alone (the callbacks stay in the process that set them)."""
    return replace(stats, on_progress=None, on_note=None)


def merge_stats(parts: List[Stats]) -> Stats:
    """Counts added, sets joined; times apart from fuzzing are the longest (workers run at once)."""
    out = Stats()
    for part in parts:
        for f in fields(Stats):
            name = f.name
            value = getattr(part, name)
            if name in ("on_progress", "on_note"):
                continue
            if name in ("startup_s", "checking_s"):
                setattr(out, name, max(getattr(out, name), value))
            elif isinstance(value, set):
                getattr(out, name).update(value)
            elif isinstance(value, dict):
                mine = getattr(out, name)
                for k, v in value.items():
                    mine[k] = mine.get(k, 0) + v
            else:
                setattr(out, name, getattr(out, name) + value)
    return out


def merge_results(parts: List[CampaignResult], stats: Stats) -> CampaignResult:
    """One result: findings by oracle (the first worker's kept, later ones counted as seen again)."""
    out = CampaignResult(seed=parts[0].seed if parts else 0, workers=len(parts))
    for part in parts:
        for confirmed in part.findings:
            known = out.finding(confirmed.oracle)
            if known is None:
                out.findings.append(confirmed)
            else:
                known.also_seen += 1 + confirmed.also_seen
        out.unconfirmed += part.unconfirmed
        out.prelude_failures += part.prelude_failures
        out.runs += part.runs
        out.cpu += part.cpu
        out.elapsed = max(out.elapsed, part.elapsed)
        out.checking = max(out.checking, part.checking)
        out.interrupted = out.interrupted or part.interrupted
        out.stopped = out.stopped or part.stopped
        out.check_limit = part.check_limit
        out.check_cut += part.check_cut
    out.not_done = not_done(out, stats)
    return out


def _worker(index: int, jobs: int, config: CampaignConfig, budget: Budget, seed: int,
            database: Optional[str], scheme: str, conn: Any) -> None:
    """One worker: its campaign, its figures sent now and then, its result at the end."""
    # Ctrl-C is the parent's to pass on (as SIGTERM); a worker never outlives it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    set_parent_death_signal(signal.SIGKILL)
    stops = StopSignals((signal.SIGTERM,), kill=lambda: os._exit(EXIT_INTERRUPTED))
    stops.__enter__()
    last = [0.0]

    def send(message: tuple) -> None:
        with stops.deferring():       # never half a message on the pipe
            conn.send(message)

    def progress(stats: Stats) -> None:
        now = time.monotonic()
        if now - last[0] >= PROGRESS_EVERY_S:
            last[0] = now
            send(("progress", index, _plain(stats)))

    config.stats = Stats(on_progress=progress, on_note=lambda text: send(("note", index, text)))
    message: tuple = ()
    try:
        result = run_campaign(config, budget, seed, database, scheme, first=index, stride=jobs,
                              replay_stored=index == 0)
        message = ("done", index, (result, _plain(config.stats)))
    except KeyboardInterrupt:
        message = ("done", index, (CampaignResult(seed=seed, interrupted=True), _plain(config.stats)))
    except TargetError as exc:
        message = ("error", index, ("target", str(exc.args[0] if exc.args else exc)))
    except Exception as exc:  # noqa: BLE001  (a worker's crash is told, not lost)
        message = ("error", index, ("crash", f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"))
    finally:
        stops.hold()                  # a SIGTERM from here on must not cut the result short
        if message:
            conn.send(message)
        release_process_resources()   # what its targets keep (sil: the booted firmwares it started)
        conn.close()


def _receive(conn: Any, open_pipes: List[Any], latest: Dict[int, Stats],
             done: Dict[int, Tuple[CampaignResult, Stats]], errors: List[Tuple[str, str]],
             on_progress: Callable[[Stats], None], on_note: Callable[[str], None]) -> None:
    """One message from a worker (a closed pipe: that worker has ended)."""
    try:
        kind, index, payload = conn.recv()
    except (EOFError, OSError):
        open_pipes.remove(conn)
        return
    if kind == "progress":
        latest[index] = payload
        on_progress(merge_stats(list(latest.values())))
    elif kind == "note":
        on_note(f"worker {index}: {payload}")
    elif kind == "done":
        done[index] = payload
        latest[index] = payload[1]
    else:
        errors.append(payload)


def _signal_all(workers: List[Any], sig: int) -> None:
    for proc in workers:
        if proc.pid is not None and proc.exitcode is None:
            try:
                os.kill(proc.pid, sig)
            except OSError:
                pass


def run_jobs(config: CampaignConfig, budget: Budget, seed: int, jobs: int, database: Optional[str],
             scheme: str, on_progress: Callable[[Stats], None], on_note: Callable[[str], None],
             stops: Optional[StopSignals] = None) -> Tuple[CampaignResult, Stats]:
    """``jobs`` campaigns at once; their merged result and figures. ``stops``: this command's
    signal handlers (a second Ctrl-C kills the workers before this process ends)."""
    try:
        context = multiprocessing.get_context("fork")
    except ValueError:
        raise ValueError("--jobs needs a system that can fork processes (Linux)") from None
    pipes, workers = [], []
    for index in range(jobs):
        mine, theirs = context.Pipe(duplex=False)
        proc = context.Process(target=_worker, name=f"fuzz-job-{index}", daemon=True,
                               args=(index, jobs, config, budget, seed, database, scheme, theirs))
        proc.start()
        theirs.close()
        pipes.append(mine)
        workers.append(proc)
    if stops is not None:
        stops.at_kill(lambda: _signal_all(workers, signal.SIGKILL))
    latest: Dict[int, Stats] = {}
    done: Dict[int, Tuple[CampaignResult, Stats]] = {}
    errors: List[Tuple[str, str]] = []
    open_pipes = list(pipes)
    while open_pipes:
        try:
            for conn in multiprocessing.connection.wait(open_pipes, timeout=1.0):
                with stops.deferring() if stops is not None else nullcontext():
                    _receive(conn, open_pipes, latest, done, errors, on_progress, on_note)
        except KeyboardInterrupt:
            # Each worker stops as at its own Ctrl-C and sends what it ran: collect it.
            _signal_all(workers, signal.SIGTERM)
    if stops is not None:
        stops.hold()                  # every result is in: a Ctrl-C now must not lose them
    for proc in workers:
        proc.join(timeout=30)
    for index, proc in enumerate(workers):
        if index not in done and not errors:
            errors.append(("crash", f"worker {index} ended without a result (exit {proc.exitcode})"))
    if errors:
        kind, message = errors[0]
        if kind == "target":
            raise TargetError(message)
        raise RuntimeError(f"a fuzzing worker failed: {message}")
    ordered = [done[i] for i in sorted(done)]
    stats = merge_stats([s for _r, s in ordered])
    stats.examples = sum(r.runs for r, _s in ordered)
    return merge_results([r for r, _s in ordered], stats), stats

"""``run --baseline OTHER``: the baseline's runs of the suite, beside the target's run.

The baseline runs as the target does (the same cases, options and pytest arguments), into
``baseline/<run>/`` beside the target's JUnit file: ``reference`` (what the target is compared
with), ``again`` (the wall clock paces some of the harness's waits, so load can move a line), and
for a ``sil:`` baseline ``phase-<ns>ns`` runs of a chip started that much later (campaigns/mutation.py's
phase controls, ``BUILDHAT_SIL_START_NS``). One of them runs beside the target's run, the rest
after it, two at a time: the machine's two cores. Each is a child in its own process group that
ends with this process; :meth:`BaselineRuns.stop` ends them on Ctrl-C.
"""
from __future__ import annotations

import argparse
import copy
import os
import signal
import subprocess
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Callable, Dict, List, Optional, Tuple

from ..plumbing.parent_death import die_with_parent
from .case_output import PHASE_CONTROLS_NS

__all__ = ["BaselineRuns", "control_names"]


def control_names(baseline: str) -> List[Tuple[str, int]]:
    """(folder name, chip start in ns) of the baseline's runs, the reference first."""
    runs = [("reference", 0), ("again", 0)]
    if baseline.startswith("sil:"):
        runs += [(f"phase-{ns}ns", ns) for ns in PHASE_CONTROLS_NS]
    return runs


class BaselineRuns:
    """The baseline's runs, started by :meth:`start` and collected by :meth:`wait`. ``slots``
    is shared with the target's run, which holds one while it runs."""

    def __init__(self, args: argparse.Namespace, folder: Path,
                 argv_for: Callable[[argparse.Namespace], List[str]], slots: threading.Semaphore):
        self.args, self.folder, self.argv_for, self.slots = args, folder, argv_for, slots
        self.names = control_names(args.baseline)
        self._procs: Dict[str, subprocess.Popen] = {}
        self._stopped = False
        self._pool = ThreadPoolExecutor(max_workers=2)
        self._futures: List[Future] = []

    def start(self) -> None:
        for name, start_ns in self.names:
            self._futures.append(self._pool.submit(self._one, name, start_ns))

    def _one(self, name: str, start_ns: int) -> Optional[int]:
        run = self.folder / name
        run.mkdir(parents=True, exist_ok=True)
        ns = copy.copy(self.args)
        ns.target, ns.junit, ns.transcripts = [self.args.baseline], str(run / "junit.xml"), None
        ns.inventory, ns.image, ns.signature = None, None, None
        argv = self.argv_for(ns)
        env = dict(os.environ, BUILDHAT_SIL_START_NS=str(start_ns)) if start_ns else None
        with self.slots:
            if self._stopped:
                return None
            with open(run / "run.log", "w", encoding="utf-8") as log:
                proc = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=env,
                                        start_new_session=True, preexec_fn=die_with_parent(signal.SIGTERM))
                self._procs[name] = proc
                return proc.wait()

    def wait(self) -> List[Path]:
        """The JUnit files of the runs that left one, the reference first (none: its run failed)."""
        for fut in self._futures:
            fut.result()
        self._pool.shutdown()
        return [self.folder / name / "junit.xml" for name, _ns in self.names
                if (self.folder / name / "junit.xml").is_file()]

    def reference_log(self) -> str:
        """The last line the reference run printed (why it left no JUnit file)."""
        try:
            lines = (self.folder / "reference" / "run.log").read_text(encoding="utf-8", errors="replace")
        except OSError:
            return "it did not start"
        last = [line for line in lines.splitlines() if line.strip()]
        return last[-1] if last else "it printed nothing"

    def stop(self) -> None:
        self._stopped = True
        for proc in self._procs.values():
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGTERM)
                except (ProcessLookupError, PermissionError):
                    pass

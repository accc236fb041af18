"""Run one scenario script (``scenarios/*.py``) under a library venv's Python, with a hard time limit.

The script gets one JSON argument ``{"pty": ..., "control": ..., "params": {...}}`` and prints one JSON
object per line (``{"name": ..., "value": ..., "t": seconds}``). Its output goes to a file, not a pipe,
so whatever it printed before a hang is still there after the kill. On timeout the whole process
group is killed (the library starts threads and timers; nothing may outlive the test).
"""
from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional

__all__ = ["ScenarioResult", "run_scenario", "SCENARIOS"]

SCENARIOS = pathlib.Path(__file__).resolve().parent / "scenarios"


@dataclass
class ScenarioResult:
    script: str
    returncode: Optional[int]
    timed_out: bool
    elapsed: float
    records: List[Dict[str, Any]] = field(default_factory=list)
    stderr: str = ""
    stdout_junk: List[str] = field(default_factory=list)   # lines that were not JSON records
    library_log: str = ""    # buildhat's own debug log (0.6+: every line it sent and received)

    @property
    def values(self) -> Dict[str, Any]:
        """name -> value of the last record with that name."""
        return {r["name"]: r.get("value") for r in self.records}

    def explain(self) -> str:
        """Everything a failing test should show: how it ended, what it printed, its traceback."""
        how = ("TIMED OUT (killed)" if self.timed_out else f"exit {self.returncode}")
        shown = "\n".join(f"  {r.get('t')}s {r['name']} = {r.get('value')!r}"[:400] for r in self.records)
        junk = "\n".join(self.stdout_junk[-10:])
        log = "\n".join(self.library_log.splitlines()[-60:])
        return (f"scenario {self.script}: {how} after {self.elapsed:.1f} s\nrecords:\n{shown}\n"
                f"other stdout:\n{junk}\nstderr (tail):\n{self.stderr[-3000:]}\n"
                f"library debug log (tail):\n{log}")


def run_scenario(python: pathlib.Path, script: str, pty: str, control: str, params: Dict[str, Any],
                 timeout: float, env_extra: Optional[Dict[str, str]] = None) -> ScenarioResult:
    """Run ``scenarios/<script>`` with ``python``; kill its process group after ``timeout`` seconds.
    ``env_extra`` overrides environment variables (e.g. ``GPIOZERO_PIN_FACTORY``)."""
    argument = json.dumps({"pty": pty, "control": control, "params": params})
    env = dict(os.environ)
    env["GPIOZERO_PIN_FACTORY"] = "mock"      # no GPIO here; only the firmware-reset pulse would use it
    env.update(env_extra or {})
    env["PYTHONUNBUFFERED"] = "1"
    env.pop("PYTHONPATH", None)               # the library venv sees only itself and the stdlib
    with tempfile.TemporaryDirectory(prefix="bh-scn-") as tmp:
        env["TMPDIR"] = tmp                   # where buildhat writes its debug log (Hat(debug=True))
        out_path = pathlib.Path(tmp) / "stdout.jsonl"
        err_path = pathlib.Path(tmp) / "stderr.txt"
        started = time.monotonic()
        with open(out_path, "wb") as out, open(err_path, "wb") as err:
            # cwd=tmp: buildhat 0.9.0 prefers a ./data/firmware.bin if one exists; there must be none.
            proc = subprocess.Popen([str(python), str(SCENARIOS / script), argument], cwd=tmp, env=env,
                                    stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                    start_new_session=True)
            timed_out = False
            try:
                proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                timed_out = True
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
            else:
                _kill_leftovers(proc.pid)
        elapsed = time.monotonic() - started
        records, junk = _parse(out_path.read_text(errors="replace"))
        logs = sorted(pathlib.Path(tmp).glob("buildhat-*.log"))
        return ScenarioResult(script, None if timed_out else proc.returncode, timed_out, elapsed,
                              records, err_path.read_text(errors="replace"), junk,
                              "\n".join(p.read_text(errors="replace") for p in logs))


def _kill_leftovers(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def _parse(text: str) -> tuple[List[Dict[str, Any]], List[str]]:
    records, junk = [], []
    for line in text.splitlines():
        try:
            obj = json.loads(line)
        except ValueError:
            junk.append(line)
            continue
        if isinstance(obj, dict) and "name" in obj:
            records.append(obj)
        else:
            junk.append(line)
    return records, junk

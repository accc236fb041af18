"""A labgrid lab on loopback (issue 23): what holding a place costs, and what a second place buys.

The lab is the repository's ``tests/lab_fixture.py``: a real labgrid-coordinator and
labgrid-exporter, two emulators at real time as the HATs of places hat-a and hat-b, exported
through ser2net, each with an HTTP digital output on its RESET pin. Without the repository,
labgrid or ser2net the figures are blank and say why.

- *Acquire and open*, *close and release*: ``labgrid:hat-a`` opened and closed in a fresh process
  (the package's target, as every command uses it), REPEATS times, medians. Acquiring includes
  the exporter starting ser2net for the place.
- *Suite on one place, on two at once*: ``buildhat-conformance run --places ... -k KEYWORD``
  (the user's command) on hat-a alone, then on both; the ratio is 1.0 when two places cost no
  more wall time than one.
"""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time
from typing import Dict

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KEYWORD = "test_select"
REPEATS = 5

_OPEN_CLOSE = """
import json, statistics, sys, time
from buildhat_conformance.harness.targets import make_target
opens, closes = [], []
for _ in range(int(sys.argv[2])):
    target = make_target(sys.argv[1])
    t0 = time.monotonic(); target.open(); t1 = time.monotonic(); target.close()
    opens.append(t1 - t0); closes.append(time.monotonic() - t1)
print(json.dumps({"open_s": statistics.median(opens), "close_s": statistics.median(closes)}))
"""


def _lab(root: pathlib.Path):  # type: ignore[no-untyped-def]
    tests = os.path.join(REPO, "tests")
    if not os.path.exists(os.path.join(tests, "lab_fixture.py")):
        raise RuntimeError("needs the repository's tests/lab_fixture.py")
    sys.path.insert(0, tests)
    try:
        import lab_fixture  # pyright: ignore[reportMissingImports]  # the repository's, not the package's
    finally:
        sys.path.remove(tests)
    why = lab_fixture.missing()
    if why:
        raise RuntimeError(why)
    return lab_fixture.Lab(root, {"hat-a": [], "hat-b": []}).start()


def _suite(lab, places: str, folder: str) -> float:  # type: ignore[no-untyped-def]
    exe = os.path.join(os.path.dirname(sys.executable), "buildhat-conformance")
    t0 = time.monotonic()
    proc = subprocess.run([exe, "run", "--places", places, "-k", KEYWORD, "--junit",
                           os.path.join(folder, "junit.xml")], env=lab.env, capture_output=True, text=True,
                          timeout=900)
    wall = time.monotonic() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"run --places {places} exited {proc.returncode}: "
                           f"{(proc.stderr or proc.stdout).strip().splitlines()[-1:]}")
    return wall


def place_costs() -> Dict:
    with tempfile.TemporaryDirectory(prefix="bench-lab-") as tmp:
        lab = _lab(pathlib.Path(tmp))
        try:
            url = f"labgrid:hat-a?coordinator={lab.address}"
            proc = subprocess.run([sys.executable, "-c", _OPEN_CLOSE, url, str(REPEATS)], env=lab.env,
                                  capture_output=True, text=True, timeout=300)
            if proc.returncode != 0:
                raise RuntimeError((proc.stderr.strip().splitlines() or ["open/close failed"])[-1])
            costs = json.loads(proc.stdout.strip().splitlines()[-1])
            one = _suite(lab, "hat-a", os.path.join(tmp, "one"))
            two = _suite(lab, "board=buildhat", os.path.join(tmp, "two"))
        finally:
            lab.stop()
    return {"open_s": costs["open_s"], "close_s": costs["close_s"], "one_s": one, "two_s": two,
            "ratio": two / one, "note": f"-k {KEYWORD} at real time; open/close median of {REPEATS}"}

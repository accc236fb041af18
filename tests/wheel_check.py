"""`make wheel-check`: the package as a user gets it, end to end (about two minutes, so not in
`make test`).

1. `python -m build` makes the sdist and the wheel; `twine check` passes on both.
2. A fresh venv gets the wheel (its dependencies from the package index), nothing else.
3. From an empty directory, `make conformance`'s own command (read from the Makefile, the venv's
   `buildhat-conformance` in place of .venv's) runs the suite against the built-in emulator.
4. It must exit 0 and leave a JUnit file with cases and no failure, and the HTML report.

Prints one line per step; exits non-zero, naming the step, at the first that fails.
"""
from __future__ import annotations

import os
import pathlib
import re
import shlex
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

REPO = pathlib.Path(__file__).resolve().parent.parent


def step(what: str, argv: list, cwd: pathlib.Path, timeout: float = 900) -> subprocess.CompletedProcess:
    print(f"wheel-check: {what}: {' '.join(shlex.quote(str(a)) for a in argv)}", flush=True)
    proc = subprocess.run([str(a) for a in argv], cwd=cwd, capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout[-3000:] + proc.stderr[-3000:])
        sys.exit(f"wheel-check: {what} failed (exit status {proc.returncode})")
    return proc


def conformance_command() -> list:
    """The Makefile's `conformance` recipe, with the default TARGET."""
    text = (REPO / "Makefile").read_text(encoding="utf-8")
    recipe = re.search(r"^conformance:.*\n((?:\t.*\n)+)", text, re.M)
    if not recipe:
        sys.exit("wheel-check: no `conformance` target in the Makefile")
    target = re.search(r"^TARGET\s*\?=\s*(\S+)", text, re.M)
    line = recipe.group(1).strip().splitlines()[-1]
    line = line.replace("$(TARGET)", target.group(1) if target else "emulator")
    return shlex.split(line.replace("$(VENV)/bin/", ""))


def main() -> int:
    with tempfile.TemporaryDirectory(prefix="wheel-check-") as tmp:
        tmp_path = pathlib.Path(tmp)
        dist = tmp_path / "dist"
        step("build", [sys.executable, "-m", "build", "--outdir", dist, REPO], REPO)
        built = sorted(dist.iterdir())
        step("twine check", [sys.executable, "-m", "twine", "check", "--strict", *built], REPO)
        wheel = next(p for p in built if p.suffix == ".whl")
        venv = tmp_path / "venv"
        step("fresh venv", [sys.executable, "-m", "venv", venv], tmp_path)
        pip = [venv / "bin" / "python", "-m", "pip", "install", "--quiet"]
        step("install the wheel", [*pip, wheel], tmp_path)
        empty = tmp_path / "empty"
        empty.mkdir()
        argv = conformance_command()
        argv[0] = str(venv / "bin" / argv[0])
        env = dict(os.environ, PATH=f"{venv / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}")
        env.pop("VIRTUAL_ENV", None)
        print(f"wheel-check: make conformance's command, from an empty directory: {shlex.join(argv)}",
              flush=True)
        proc = subprocess.run(argv, cwd=empty, env=env, capture_output=True, text=True, timeout=1800)
        if proc.returncode != 0:
            sys.stderr.write(proc.stdout[-3000:] + proc.stderr[-3000:])
            sys.exit(f"wheel-check: the suite from the wheel exited with {proc.returncode}")
        junit = empty / "reports" / "junit.xml"
        html = empty / "reports" / "index.html"
        if not junit.is_file() or not html.is_file():
            sys.exit(f"wheel-check: no {junit.name} or {html.name} in {empty / 'reports'}")
        root = ET.parse(junit).getroot()
        suites = [root] if root.tag == "testsuite" else list(root)
        cases = sum(int(s.get("tests", 0)) for s in suites)
        failed = sum(int(s.get("failures", 0)) + int(s.get("errors", 0)) for s in suites)
        if cases == 0 or failed:
            sys.exit(f"wheel-check: the suite from the wheel ran {cases} cases, {failed} failed")
        print(f"wheel-check: ok: {wheel.name} and the sdist pass twine check; from the wheel in a fresh "
              f"venv the suite ran {cases} cases, none failed, and wrote reports/junit.xml and index.html")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Virtual environments holding one released ``buildhat`` library each, built once and reused.

``buildhat_python("0.9.0")`` returns the interpreter of ``<repo>/.venv-hostlib/0.9.0/`` (next to the
project's own ``.venv``), creating it with ``python -m venv`` and pip from PyPI the first time. A venv is
used only when its stamp file says it finished installing exactly the pinned requirements, so a build that
was interrupted is thrown away and redone. A file lock serialises builders (several test processes, or
other engineers' tests, may ask for the same version at once).

If PyPI cannot be reached, :class:`HostLibUnavailable` is raised with pip's own words, and the test fails
with them: every test that installs is marked ``network``, and a run without the network leaves those out on
purpose (``-m "not network"`` or ``BUILDHAT_TESTS_OFFLINE=1``, tests/conftest.py), never by an install
failure. Any other pip failure is a real error and propagates.

Command line (for CI scripts): ``python tests/hostlib/venvs.py 0.9.0`` prints the interpreter path.
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import importlib.metadata
import importlib.util
import os
import pathlib
import shutil
import subprocess
import sys
from typing import Dict, Iterator, List

__all__ = ["SUPPORTED", "FIRMWARE_OF", "WITH_PROJECT", "HostLibUnavailable", "buildhat_python", "venv_root",
           "requirements"]

REPO = pathlib.Path(__file__).resolve().parents[2]

#: The library releases the CI gate runs, each with the firmware its package bundles
#: (``buildhat/data/version``): 0.9.0 is the current release, 0.5.7 the newest that uploads R2, 0.5.12 the
#: last 0.5.x (it uploads R5 1670596313 after resetting the HAT through gpiozero when the version differs).
FIRMWARE_OF: Dict[str, int] = {"0.9.0": 1737564117, "0.5.7": 1636109636, "0.5.12": 1670596313}
#: The releases the scenario matrix of tests/end_to_end/test_hostlib_python_build_hat.py runs.
SUPPORTED = ("0.9.0", "0.5.7")
#: Releases whose venv also holds this project (editable, no dependencies) and pytest, as a host library's CI
#: would install them: 0.5.12 for the gpiozero pin factory entry point (``GPIOZERO_PIN_FACTORY=
#: buildhat_emulator``), 0.9.0 for a pytest session of the library on the shared-emulator fixture.
WITH_PROJECT = frozenset({"0.5.12", "0.9.0"})
_PROJECT_PINS = ["pytest==8.3.5"]

# Pins beside the library: gpiozero 2.x still imports on Python 3.9 and offers the mock pin factory the
# scenarios select (there is no GPIO here). Pinning keeps the venv the same from run to run.
_EXTRA_PINS = ["gpiozero==2.0.1", "pyserial==3.5"]

# pip's words for "could not reach the index"; with --quiet an unreachable index often shows only as
# "no version found", which a reachable index would say only if the pinned release had been removed.
_NETWORK_SIGNS = ("NewConnectionError", "Temporary failure in name resolution", "Network is unreachable",
                  "ConnectTimeoutError", "ReadTimeoutError", "Max retries exceeded", "ProxyError",
                  "Connection refused", "SSLError")
_NOT_FOUND_SIGNS = ("No matching distribution found", "Could not find a version that satisfies")


class HostLibUnavailable(RuntimeError):
    """The library could not be installed because its package index is out of reach."""


def venv_root() -> pathlib.Path:
    """Where the library venvs live (``BUILDHAT_HOSTLIB_VENVS`` overrides, e.g. for a CI cache)."""
    override = os.environ.get("BUILDHAT_HOSTLIB_VENVS")
    return pathlib.Path(override) if override else REPO / ".venv-hostlib"


def requirements(version: str) -> List[str]:
    """The exact requirement lines installed into the venv of ``version``."""
    if version not in FIRMWARE_OF:
        raise ValueError(f"buildhat {version} is not one the gate runs; known: {', '.join(FIRMWARE_OF)}")
    return [f"buildhat=={version}"] + _EXTRA_PINS + (_PROJECT_PINS if version in WITH_PROJECT else [])


def _python_in(venv: pathlib.Path) -> pathlib.Path:
    return venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def _project_fingerprint() -> str:
    """What an editable install of this project depends on: its entry points and setup.py's package map
    (not the rest of pyproject.toml, so that a new dependency elsewhere does not rebuild the venvs)."""
    digest = hashlib.sha256((REPO / "setup.py").read_bytes())
    section = False
    for line in (REPO / "pyproject.toml").read_text(encoding="utf-8").splitlines():
        if line.startswith("["):
            section = line.startswith("[project.entry-points")
        if section:
            digest.update(line.encode() + b"\n")
    return f"project {REPO} {digest.hexdigest()[:16]}"


def _stamp_text(version: str) -> str:
    # The stamp names the interpreter too: a venv made by another Python must not be reused.
    lines = requirements(version) + [f"python {sys.version_info[0]}.{sys.version_info[1]}"]
    if version in WITH_PROJECT:
        lines.append(_project_fingerprint())
    return "\n".join(lines) + "\n"


def _is_ready(venv: pathlib.Path, version: str) -> bool:
    stamp = venv / ".hostlib-ready"
    return (_python_in(venv).exists() and stamp.is_file()
            and stamp.read_text(encoding="utf-8") == _stamp_text(version))


@contextlib.contextmanager
def _locked(path: pathlib.Path) -> Iterator[None]:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _run(cmd: List[str], timeout: float) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout,
                          env={**os.environ, "PIP_DISABLE_PIP_VERSION_CHECK": "1"})


def _outer_pip() -> bool:
    """Our interpreter has a pip that can install into another environment (``--python``, pip 22.3+)."""
    if importlib.util.find_spec("pip") is None:
        return False
    try:
        major, minor = (int(x) for x in importlib.metadata.version("pip").split(".")[:2])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return False
    return (major, minor) >= (22, 3)


def _build(venv: pathlib.Path, version: str) -> None:
    if venv.exists():
        shutil.rmtree(venv)  # an unfinished build: its contents cannot be trusted
    # Without ensurepip the venv is made in about a second instead of several (half a minute on a
    # loaded machine); our own pip installs into it. Otherwise the venv gets a pip of its own.
    outer_pip = _outer_pip()
    made = _run([sys.executable, "-m", "venv"] + (["--without-pip"] if outer_pip else []) + [str(venv)],
                timeout=300)
    if made.returncode != 0:
        raise RuntimeError(f"python -m venv {venv} failed:\n{made.stdout}")
    pip = [sys.executable, "-m", "pip", "--python", str(_python_in(venv))] if outer_pip else \
        [str(_python_in(venv)), "-m", "pip"]
    try:
        done = _run(pip + ["install", "--no-input", "--quiet", *requirements(version)], timeout=600)
    except subprocess.TimeoutExpired as exc:
        shutil.rmtree(venv, ignore_errors=True)
        raise HostLibUnavailable(
            f"PyPI unreachable? pip install buildhat=={version} took over 600 s") from exc
    if done.returncode != 0:
        shutil.rmtree(venv, ignore_errors=True)
        tail = "\n".join(done.stdout.strip().splitlines()[-6:])
        if any(sign in done.stdout for sign in _NETWORK_SIGNS):
            raise HostLibUnavailable(f"PyPI unreachable: pip install buildhat=={version} failed:\n{tail}")
        if any(sign in done.stdout for sign in _NOT_FOUND_SIGNS):
            raise HostLibUnavailable(f"PyPI unreachable (or buildhat=={version} withdrawn): pip found no "
                                     f"such release:\n{tail}")
        raise RuntimeError(f"pip install buildhat=={version} failed:\n{tail}")
    if version in WITH_PROJECT:
        done = _run(pip + ["install", "--no-input", "--quiet", "--no-deps", "-e", str(REPO)], timeout=600)
        if done.returncode != 0:
            shutil.rmtree(venv, ignore_errors=True)
            tail = "\n".join(done.stdout.strip().splitlines()[-6:])
            if any(sign in done.stdout for sign in _NETWORK_SIGNS):
                raise HostLibUnavailable(f"PyPI unreachable: installing this project (build backend) "
                                         f"failed:\n{tail}")
            raise RuntimeError(f"pip install -e {REPO} into the buildhat {version} venv failed:\n{tail}")
    (venv / ".hostlib-ready").write_text(_stamp_text(version), encoding="utf-8")


def buildhat_python(version: str) -> pathlib.Path:
    """The Python interpreter of a venv with ``buildhat==version`` installed (built on first use)."""
    venv = venv_root() / version
    if _is_ready(venv, version):
        return _python_in(venv)  # the fast path: no lock, no subprocess
    with _locked(venv_root() / f".{version}.lock"):
        if not _is_ready(venv, version):  # another process may have built it while we waited
            _build(venv, version)
    return _python_in(venv)


def main(argv: List[str]) -> int:
    if len(argv) != 1:
        print(f"usage: venvs.py VERSION   (one of {', '.join(FIRMWARE_OF)})", file=sys.stderr)
        return 2
    try:
        print(buildhat_python(argv[0]))
    except HostLibUnavailable as exc:
        print(exc, file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

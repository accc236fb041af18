"""tests/hostlib/venvs.py: the library venvs are built once and reused, and an unreachable package index
becomes a HostLibUnavailable that says so (a test marked ``network`` fails with it), never a silent pass."""
from __future__ import annotations

import pathlib
import subprocess
import time

import pytest

from hostlib import venvs  # noqa: E402

pytestmark = pytest.mark.timeout(300)


def test_unknown_version_is_refused() -> None:
    with pytest.raises(ValueError, match="0.9.0"):
        venvs.requirements("0.1.0")


def test_unreachable_index_says_pypi_unreachable(tmp_path: pathlib.Path, monkeypatch) -> None:
    monkeypatch.setenv("BUILDHAT_HOSTLIB_VENVS", str(tmp_path))
    monkeypatch.setenv("PIP_INDEX_URL", "http://127.0.0.1:9/simple")   # nothing listens on port 9
    monkeypatch.setenv("PIP_FIND_LINKS", "")
    monkeypatch.setenv("PIP_RETRIES", "0")
    monkeypatch.setenv("PIP_DEFAULT_TIMEOUT", "3")
    with pytest.raises(venvs.HostLibUnavailable, match="PyPI unreachable"):
        venvs.buildhat_python("0.5.7")
    assert not (tmp_path / "0.5.7").exists()          # a failed build leaves nothing to be reused


@pytest.mark.parametrize("version", venvs.SUPPORTED)
@pytest.mark.network
def test_venv_is_reused_and_holds_the_pinned_library(version: str) -> None:
    python = venvs.buildhat_python(version)     # from PyPI: a failed install fails (the test is marked)
    started = time.monotonic()
    assert venvs.buildhat_python(version) == python
    assert time.monotonic() - started < 0.5           # the fast path: a stamp check, no pip
    probe = ("import importlib.metadata as m, buildhat, os;"
             "d = os.path.join(os.path.dirname(buildhat.__file__), 'data', 'version');"
             "print(m.version('buildhat'), open(d).read().strip())")
    out = subprocess.run([str(python), "-c", probe], capture_output=True, text=True, timeout=60,
                         env={"GPIOZERO_PIN_FACTORY": "mock", "PATH": "/usr/bin:/bin"})
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == [version, str(venvs.FIRMWARE_OF[version])]

"""What a user gets without shared/: the formats documents, a licence, hints that work, no
placeholders. (The built wheel itself is checked by `make wheel-check`, tests/wheel_check.py.)"""
from __future__ import annotations

import pathlib
import re
import sys

import pytest
from repo_paths import REPO
from shared_material import need_shared

FORMATS = ("SCENARIO-SCRIPT.md", "TRANSCRIPT.md")
# Everything a user reads or runs: the package's folders, the docs, the examples, the top-level files.
USER_TOPS = ("protocol", "harness", "emulator", "conformance", "fuzz", "bench", "buildhat_conformance",
             "docs", "examples", "transcripts")
USER_SUFFIXES = (".py", ".md", ".yml", ".html", ".toml", ".json")
USER_FILES = [p for top in USER_TOPS for p in (REPO / top).rglob("*")
              if p.suffix in USER_SUFFIXES and "__pycache__" not in p.parts] \
    + [REPO / "README.md", REPO / "pyproject.toml", REPO / "Makefile"]


@pytest.mark.parametrize("name", FORMATS)
def test_formats_documents_are_the_interchange_formats(name):
    """docs/formats/ is the project's copy of the interchange formats: word for word."""
    ours = (REPO / "docs" / "formats" / name).read_bytes()
    original = need_shared("formats", name, what="the originals of docs/formats/")
    assert ours == original.read_bytes(), \
        f"docs/formats/{name} differs from shared/formats/{name}: copy it again"


def test_licence_is_bsd_3_clause_and_declared():
    text = (REPO / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("BSD 3-Clause License") and "Neither the name of the copyright holder" in text
    pyproject = (REPO / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r'^license = "BSD-3-Clause"$', pyproject, re.M)
    assert "[project.urls]" in pyproject


def test_no_placeholders_and_no_pointers_into_shared():
    bad = []
    for path in USER_FILES:
        # DEVELOPING.md names shared/ as the developers' source of truth (a test keeps the copy equal)
        if path.name in FORMATS + ("DEVELOPING.md",) or not path.is_file():
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if re.search(r"<owner>|\bOWNER\b|shared/formats", line):
                bad.append(f"{path.relative_to(REPO)}:{n}: {line.strip()}")
    assert not bad, "\n".join(bad)


def test_no_install_hint_names_the_package_on_an_index():
    """`pip install 'buildhat-conformance[...]'` fetches nothing of ours: it is installed from a
    checkout or a built wheel."""
    bad = [f"{p.relative_to(REPO)}:{n}" for p in USER_FILES if p.is_file()
           for n, line in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines(), 1)
           if re.search(r"pip install ['\"]?buildhat-conformance\b", line)]
    assert not bad, bad


# Run in a child: setuptools' distutils shim must not meet a distutils another test imported.
_MANIFEST_FILES = """
import json, os, sys
from setuptools.command.egg_info import FileList
repo = sys.argv[1]
found = []
for here, dirs, files in os.walk(repo):
    dirs[:] = [d for d in dirs if not d.startswith(".")]      # .venv, .git
    found += [os.path.relpath(os.path.join(here, f), repo) for f in files]
manifest = FileList()
manifest.allfiles = found
with open(os.path.join(repo, "MANIFEST.in"), encoding="utf-8") as fh:
    for line in fh:
        if line.strip() and not line.startswith("#"):
            manifest.process_template_line(line)
print(json.dumps(manifest.files))
"""


def test_sdist_manifest_carries_docs_examples_and_golden_transcripts():
    """What `python -m build --sdist` takes besides the package (MANIFEST.in, as setuptools
    reads it), checked against the files that exist, so a new document or golden file cannot
    be left out."""
    import json
    import subprocess

    proc = subprocess.run([sys.executable, "-c", _MANIFEST_FILES, str(REPO)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    files = json.loads(proc.stdout)
    carried = {(REPO / f).resolve() for f in files}
    wanted = [REPO / "LICENSE", REPO / "README.md", REPO / "Makefile",
              REPO / "examples" / "github-actions-host-library.yml",
              *(REPO / "docs").rglob("*.md"),
              *(p for p in (REPO / "transcripts" / "data").rglob("*") if p.is_file())]
    missing = [str(p.relative_to(REPO)) for p in wanted if p.resolve() not in carried]
    assert not missing, missing
    assert not any("reports" in pathlib.Path(f).parts for f in files)


@pytest.mark.network        # `build` fetches the build backend from PyPI into its isolated env
def test_the_firmware_stand_in_ships_as_source_and_no_firmware_does(tmp_path):
    """The wheel carries the stand-in's C (built on the user's machine by `sil build`), stays pure
    Python, and carries nothing of any firmware tree."""
    import subprocess
    import zipfile

    proc = subprocess.run([sys.executable, "-m", "build", "--wheel", "-o", str(tmp_path), str(REPO)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    wheel = next(tmp_path.glob("*.whl"))
    assert wheel.name.endswith("-py3-none-any.whl")
    names = zipfile.ZipFile(wheel).namelist()
    standin = REPO / "sil" / "standin"
    for src in [*standin.glob("*.c"), *standin.glob("*.h"), *standin.rglob("include/**/*.h")]:
        assert f"buildhat_conformance/sil/standin/{src.relative_to(standin).as_posix()}" in names
    assert not [n for n in names if n.endswith((".so", ".o")) or "firmware-pico" in n]
    ours = {p.name for p in standin.glob("*.c")}
    assert ours == {"adc.c", "board.c", "boot_signature.c", "clocks.c", "frame_transport.c", "gpio.c",
                    "i2c.c", "machine.c", "pio.c", "power_on.c", "uart.c", "wire.c"}


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-q"]))

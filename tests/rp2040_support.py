"""What the rp2040 tests share: Node.js with the pinned rp2040js, the boot ROM from ../shared, the
released images (downloaded with pip into the cache), and a runner started with a program of the
test's own. Each skips with its reason when what it needs is absent."""
from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
from typing import Dict, List, Sequence

import pytest
from shared_material import need_shared

from buildhat_conformance.harness.targets.base import TargetError
from buildhat_conformance.rp2040 import install
from buildhat_conformance.sil.process import FirmwareProcess

#: The buildhat package that carries each release's image (issue 35).
PACKAGES: Dict[str, str] = {"R1": "0.5.4", "R2": "0.5.7", "R3": "0.5.8", "R5": "0.5.12", "R6": "0.6.0",
                            "R7": "0.9.0"}


def bootrom() -> pathlib.Path:
    return need_shared("rp2040", "bootrom-b1.bin", what="the RP2040 boot ROM")


def rp2040js() -> pathlib.Path:
    if shutil.which("node") is None:
        pytest.skip("Node.js is not installed (node not on PATH)")
    try:
        return install.check_rp2040js()
    except TargetError as exc:
        pytest.skip(str(exc))


def images_dir() -> pathlib.Path:
    """Where the tests keep the released wheels (``pip download``, by .ci/run or the Makefile)."""
    return install.cache_root() / "buildhat-wheels"


def image_wheels(release: str) -> pathlib.Path:
    """The folder holding ``release``'s buildhat wheel, or skip saying how to get it."""
    version = PACKAGES[release]
    folder = images_dir()
    if not list(folder.glob(f"buildhat-{version}-*.whl")):
        pytest.skip(f"no buildhat {version} wheel (the {release} image) in {folder}; "
                    f"pip download --no-deps buildhat=={version} -d {folder}")
    return folder


def fetch_wheels(releases: Sequence[str] = tuple(PACKAGES)) -> List[str]:
    """pip download the releases' wheels into :func:`images_dir` (what .ci/run does); failures listed."""
    failed = []
    for release in releases:
        version = PACKAGES[release]
        if list(images_dir().glob(f"buildhat-{version}-*.whl")):
            continue
        done = subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
                               f"buildhat=={version}", "-d", str(images_dir())], capture_output=True)
        if done.returncode != 0:
            failed.append(version)
    return failed


def start_program(tmp_path: pathlib.Path, program: bytes, args: Sequence[str] = ()) -> FirmwareProcess:
    """The runner with ``program`` (Thumb code of the test's own) as the image, started at its first
    word like a firmware; it speaks sil's frames."""
    image = tmp_path / "program.bin"
    image.write_bytes(program + bytes(-len(program) % 4))
    return start_image(image, args)


def start_image(image: pathlib.Path, args: Sequence[str] = ()) -> FirmwareProcess:
    """The runner with ``image`` (a released firmware.bin, or a program of the test's own)."""
    folder = rp2040js()
    command = [str(install.runner_path()), "--rp2040js", str(folder), "--bootrom", str(bootrom()),
               "--image", str(image), *args]
    return FirmwareProcess(shutil.which("node") or "node", env=dict(os.environ), args=command)


if __name__ == "__main__":        # .ci/run: fetch the images before the tests
    missing = fetch_wheels()
    print(f"not downloaded: buildhat {', '.join(missing)}" if missing else "ok")
    sys.exit(1 if missing else 0)

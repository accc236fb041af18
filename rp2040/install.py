"""What the ``rp2040:`` target needs beside Python: Node.js, a pinned rp2040js, the chip's boot ROM.

rp2040js (npm, MIT) is installed once, by ``buildhat-conformance rp2040 setup``, into the project's
cache (``~/.cache/buildhat-conformance/rp2040js``), never into the package. The boot ROM is not in
the npm package: users supply their own copy (built from Raspberry Pi's ``pico-bootrom``, or read
out of any RP2040 board) at ``?bootrom=FILE``, ``$BUILDHAT_RP2040_BOOTROM`` or the default place.
Each thing missing is one line saying what to do.
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path
from typing import List, Optional, Sequence

from ..harness.targets.base import TargetError

__all__ = ["RP2040JS_VERSION", "BOOTROM_ENV", "cache_root", "rp2040js_dir", "node_program", "runner_path",
           "find_bootrom", "default_bootrom", "install_rp2040js", "runner_command"]

#: The rp2040js release the runner was written and checked against (its PL011 is corrected in
#: runner.mjs; another release may change what needs correcting).
RP2040JS_VERSION = "1.4.1"
BOOTROM_ENV = "BUILDHAT_RP2040_BOOTROM"
BOOTROM_SIZE = 16 * 1024


def cache_root() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "buildhat-conformance"


def rp2040js_dir() -> Path:
    """Where ``rp2040 setup`` installs rp2040js (a folder with ``node_modules/rp2040js``)."""
    return cache_root() / "rp2040js"


def default_bootrom() -> Path:
    """The documented default place of the user's boot ROM."""
    return cache_root() / "rp2040-bootrom.bin"


def runner_path() -> Path:
    return Path(__file__).resolve().with_name("runner.mjs")


def node_program() -> str:
    node = shutil.which("node")
    if node is None:
        raise TargetError("rp2040: Node.js is not installed (node not on PATH); install Node.js 18 or later, "
                          "then run 'buildhat-conformance rp2040 setup'")
    return node


def _installed_version(folder: Path) -> Optional[str]:
    import json
    try:
        meta = json.loads((folder / "node_modules" / "rp2040js" / "package.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return str(meta.get("version")) if isinstance(meta, dict) else None


def check_rp2040js(folder: Optional[Path] = None) -> Path:
    """The folder holding the pinned rp2040js, or a TargetError saying how to install it."""
    folder = folder or rp2040js_dir()
    have = _installed_version(folder)
    if have != RP2040JS_VERSION:
        what = "is not installed" if have is None else f"{have} is installed, not {RP2040JS_VERSION}"
        raise TargetError(f"rp2040: rp2040js {RP2040JS_VERSION} {what} in {folder}; "
                          "run 'buildhat-conformance rp2040 setup' once")
    return folder


def find_bootrom(given: Optional[str] = None) -> Path:
    """The boot ROM: ``given`` (the URL's ``?bootrom=``), else ``$BUILDHAT_RP2040_BOOTROM``, else the
    default place; a TargetError in one line when there is none."""
    where = given or os.environ.get(BOOTROM_ENV) or str(default_bootrom())
    path = Path(os.path.expanduser(where))
    if not path.is_file():
        raise TargetError(f"rp2040: no RP2040 boot ROM at {path}; copy the chip's 16 KiB boot ROM (built "
                          f"from Raspberry Pi's pico-bootrom, or read out of an RP2040) there, or name it "
                          f"with ?bootrom=FILE or ${BOOTROM_ENV}")
    size = path.stat().st_size
    if size != BOOTROM_SIZE:
        raise TargetError(f"rp2040: {path} is {size} bytes, not an RP2040 boot ROM ({BOOTROM_SIZE} bytes)")
    return path


def install_rp2040js(folder: Optional[Path] = None) -> Path:
    """``npm install`` the pinned rp2040js into ``folder`` (default: the cache). Raises RuntimeError
    with npm's last line when it fails."""
    folder = folder or rp2040js_dir()
    if _installed_version(folder) == RP2040JS_VERSION:
        return folder
    npm = shutil.which("npm")
    if npm is None:
        raise RuntimeError("npm is not installed (it comes with Node.js 18 or later)")
    folder.mkdir(parents=True, exist_ok=True)
    manifest = folder / "package.json"
    if not manifest.exists():
        manifest.write_text('{"name": "buildhat-conformance-rp2040js", "private": true}\n', encoding="utf-8")
    done = subprocess.run([npm, "install", "--no-audit", "--no-fund", "--save-exact",
                           f"rp2040js@{RP2040JS_VERSION}"], cwd=folder, capture_output=True, text=True)
    if done.returncode != 0 or _installed_version(folder) != RP2040JS_VERSION:
        last = (done.stderr.strip() or done.stdout.strip() or "no output").splitlines()[-1]
        raise RuntimeError(f"npm install rp2040js@{RP2040JS_VERSION} failed: {last}")
    return folder


def runner_command(image: Path, bootrom: Path, extra: Sequence[str] = ()) -> List[str]:
    """The command that runs ``image`` on the emulated chip, speaking sil's frames (sil/frames.py)."""
    return [node_program(), str(runner_path()), "--rp2040js", str(check_rp2040js()),
            "--bootrom", str(bootrom), "--image", str(image), *extra]
